"""tools/navigation/navigation_classifier.py: SPEC section 15's classifier in numpy, as the
offline navigation screen uses it. Its labels and windows are the Rust classifier's
(crates/defender/src/classifier.rs, whose unit tests give the same cases), its hand-written
backpropagation is the loss's gradient, it learns a failure that shows in the state, and it is
measured as the screen measures a filter. numpy only; seconds.
"""

from __future__ import annotations

import os
import pathlib
import sys

import numpy as np

SOURCE = pathlib.Path(os.environ.get("DEFENDER_SOURCE_TREE", pathlib.Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(SOURCE / "tools" / "navigation"))
import navigation_classifier as nc  # noqa: E402


def test_labels_mark_the_last_horizon_steps_of_an_unsafe_episode_only():
    assert nc.labels(5, True, 2).tolist() == [0, 0, 0, 1, 1]
    assert nc.labels(5, False, 2).tolist() == [0] * 5
    assert nc.labels(2, True, 9).tolist() == [1, 1]


def test_the_window_repeats_the_first_state_before_the_episode_is_long_enough():
    states = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    x = nc.windows(states)
    assert x.shape == (3, nc.WINDOW * 2)
    assert x[0].tolist() == [1.0, 10.0] * 5
    assert x[2].tolist() == [1.0, 10.0, 1.0, 10.0, 1.0, 10.0, 2.0, 20.0, 3.0, 30.0]


def test_the_gradients_are_the_losss():
    rng = np.random.default_rng(1)
    net = nc.Net(6, rng)
    net.params = [p.astype(np.float64) for p in net.params]
    x, y = rng.normal(size=(9, 6)), (rng.uniform(size=9) > 0.5).astype(np.float64)
    grads = net.gradients(x, y)
    for p, g in zip(net.params, grads):
        for i in rng.choice(p.size, size=min(p.size, 5), replace=False):
            idx = np.unravel_index(i, p.shape)
            keep = p[idx]
            p[idx] = keep + 1e-6
            up = net.loss(x, y)
            p[idx] = keep - 1e-6
            down = net.loss(x, y)
            p[idx] = keep
            assert abs((up - down) / 2e-6 - g[idx]) < 1e-6 * max(1.0, abs(g[idx]))


def episodes(rng, n_safe: int, n_unsafe: int, length: int = 60):
    """Column 0 rises over the last 15 steps of an unsafe episode; the rest is noise."""
    out = []
    for unsafe in [False] * n_safe + [True] * n_unsafe:
        s = rng.normal(size=(length, 3))
        if unsafe:
            s[-15:, 0] += np.linspace(2, 6, 15)
        out.append((s, unsafe))
    return out


def test_it_learns_a_failure_that_shows_in_the_state_and_is_measured_as_the_screen_measures(monkeypatch):
    rng = np.random.default_rng(0)
    demos, held = episodes(rng, 10, 10), episodes(rng, 20, 20)
    monkeypatch.setattr(nc, "PRETRAIN", 600)
    made = nc.replay(lambda: nc.Classifier(demos, 10, seed=0), held, (0.5, 0.9), learns=False)
    for r in made.values():
        assert (r["unsafe"], r["safe"]) == (20, 20)
        assert r["caught_pct"] >= 90 and r["false_alarm_pct"] <= 10
        assert 1 <= r["mean_lead"] <= 15  # it fires once the rise shows, before the last step


class Fixed:
    """A stand-in whose probability is 1 from a given step of each episode on (by its length)."""

    def __init__(self, fire_at: dict[int, int]):
        self.fire_at, self.joined = fire_at, []

    def probabilities(self, states):
        p = np.zeros(len(states))
        if len(states) in self.fire_at:
            p[self.fire_at[len(states)] :] = 1.0
        return p

    def end(self, states, unsafe):
        self.joined.append((len(states), unsafe))


def test_caught_false_alarms_and_lead_count_as_the_screen_counts():
    # Unsafe episodes of 30 and 40 decisions, safe ones of 50 and 60; it fires on the 30 at step 25
    # (lead 5) and on the 60 at step 0: one of two caught, one of two safe ended.
    held = [(np.zeros((n, 2)), n < 50) for n in (30, 40, 50, 60)]
    stub = Fixed({30: 25, 60: 0})
    r = nc.replay(lambda: stub, held, (0.5,))[0.5]
    assert (r["caught"], r["unsafe"], r["false_alarms"], r["safe"]) == (1, 2, 1, 2)
    assert r["caught_pct"] == 50.0 and r["false_alarm_pct"] == 50.0 and r["mean_lead"] == 5.0
    assert stub.joined == [(40, True), (50, False)]  # the episodes it did not end, in order


def test_the_choice_takes_the_most_caught_within_the_false_alarm_bound():
    cv = {
        (10, 0.5): {"caught_pct": 80.0, "false_alarm_pct": 30.0},
        (10, 0.9): {"caught_pct": 40.0, "false_alarm_pct": 8.0},
        (30, 0.5): {"caught_pct": 60.0, "false_alarm_pct": 10.0},
        (30, 0.9): {"caught_pct": 20.0, "false_alarm_pct": 0.0},
    }
    assert nc.choose(cv) == (30, 0.5)
    assert nc.choose({k: {**v, "false_alarm_pct": v["false_alarm_pct"] + 50} for k, v in cv.items()}) == (30, 0.9)
