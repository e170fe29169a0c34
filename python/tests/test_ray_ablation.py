"""The offline ablation spread over a local Ray cluster (``defender_rl.ray_ablation``): the parts
of each task's episodes merge to exactly what one process computes, over several tasks as
``defender ablate`` ranks them, with ``Equal`` included; bad input fails before Ray is asked."""

from __future__ import annotations

import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderError, EpisodeSet
from defender_rl.ray_ablation import ablate_on_ray, split_episodes


def random_walks(rng, lengths, crashed, drift):
    """Episodes of a 2-D random walk (1-D actions); crashed ones drift away at the end."""
    obs, act, rew = [], [], []
    for n, c in zip(lengths, crashed):
        steps = rng.normal(scale=0.1, size=(n, 2)) + (drift * np.linspace(0, 1, n)[:, None] if c else 0)
        obs.append(np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)]))
        act.append(rng.uniform(-1, 1, size=(n, 1)))
        rew.append(np.ones(n))
    return EpisodeSet.from_arrays(
        np.vstack(obs).astype(np.float32),
        np.vstack(act).astype(np.float32),
        np.concatenate(rew).astype(np.float32),
        np.asarray(lengths, dtype=np.int64),
        np.asarray(crashed, dtype=bool),
        {"env_id": "Walk-v0"},
    )


def task(seed, drift):
    rng = np.random.default_rng(seed)
    demos = random_walks(rng, [30, 34, 28, 31, 25, 22, 27, 24], [False] * 4 + [True] * 4, drift)
    n = 14
    lengths = rng.integers(5, 45, size=n).tolist()
    episodes = random_walks(rng, lengths, (rng.random(n) < 0.6).tolist(), drift)
    return demos, episodes


@pytest.fixture(scope="module")
def local_ray():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def test_split_episodes_is_a_balanced_partition():
    _, episodes = task(0, 1.0)
    parts = split_episodes(episodes, 3)
    assert len(parts) == 3 and sum(len(p) for p in parts) == len(episodes)
    assert sum(p.transitions for p in parts) == episodes.transitions
    seen = sorted(tuple(p.episode(i)["rew"].shape) + (float(p.episode(i)["obs"].sum()),) for p in parts for i in range(len(p)))
    want = sorted(tuple(episodes.episode(i)["rew"].shape) + (float(episodes.episode(i)["obs"].sum()),) for i in range(len(episodes)))
    assert seen == want, "every episode in exactly one part"
    cost = [sum(len(p.episode(i)["rew"]) ** 3 for i in range(len(p))) for p in parts]
    assert max(cost) <= 2 * min(cost)
    assert len(split_episodes(episodes, 100)) == len(episodes)
    with pytest.raises(ValueError, match="parts"):
        split_episodes(episodes, 0)


def test_ray_parts_merge_to_the_one_process_ablation(local_ray, tmp_path):
    tasks = [task(1, 1.5), task(2, 0.8)]
    out = tmp_path / "scores.csv"
    rows = ablate_on_ray(tasks, parts_per_task=3, out=out)
    assert len(rows) == 576 and [r["rank"] for r in rows] == list(range(1, 577))

    # What one process computes, task by task, and the mean over tasks (as `defender ablate`).
    direct = [{r["strategy"]: r for r in defender_rl.ablate(d, e)} for d, e in tasks]
    for r in rows:
        per_task = [t[r["strategy"]] for t in direct]
        for key in ("mean_ratio", "safe_rate", "score"):
            assert r[key] == pytest.approx(np.mean([p[key] for p in per_task]), rel=1e-12, abs=1e-15)
        assert r["strategy"] == f"{r['safe']}/{r['unsafe']}" and r["mode"] == "state"
    assert all((a["score"], b["strategy"]) >= (b["score"], a["strategy"]) for a, b in zip(rows, rows[1:]))
    # The Equal window is among what was scored.
    assert any("Equal" in r["strategy"] for r in rows)

    # The CSV of SPEC section 9, read back by numpy.
    table = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert list(table.dtype.names) == ["rank", "strategy", "safe_method", "unsafe_method", "mode", "mean_ratio", "safe_rate", "score"]
    assert len(table) == 576 and table["strategy"][0] == rows[0]["strategy"]
    np.testing.assert_array_equal(table["score"], [r["score"] for r in rows])

    # One task, a few strategies, state-action, no Equal.
    few = ablate_on_ray(tasks[:1], mode="state-action", no_equal=True, strategies=["MinBoth/MinEqual", "MeanDemoW5/MeanDemoW10", "MinDemoW5/MinDemoW10"])
    assert [r["strategy"] for r in few] == [r["strategy"] for r in defender_rl.ablate(*tasks[0], mode="state-action", strategies=["MeanDemoW5/MeanDemoW10", "MinDemoW5/MinDemoW10"])]


def test_bad_input_fails_before_any_ray_task(local_ray):
    demos, episodes = task(3, 1.0)
    with pytest.raises(DefenderError, match="Nope"):
        ablate_on_ray([(demos, episodes)], strategies=["Nope/MinBoth"])
    with pytest.raises(DefenderError, match="mode"):
        ablate_on_ray([(demos, episodes)], mode="both")
    wide = random_walks(np.random.default_rng(0), [10, 12], [False, True], 1.0)
    hopper = EpisodeSet.from_arrays(**{**wide.to_arrays(), "obs": np.zeros((24, 3), np.float32), "meta": {"env_id": "Walk-v0"}})
    with pytest.raises(DefenderError, match="dimensions|obs_dim|columns"):
        ablate_on_ray([(demos, hopper)])
    with pytest.raises(ValueError, match="empty"):
        ablate_on_ray([])
    with pytest.raises(ValueError, match="no strategy left"):
        ablate_on_ray([(demos, episodes)], strategies=["MinEqual/MinEqual"], no_equal=True)
    with pytest.raises(TypeError, match="tasks\\[0\\] episodes"):
        ablate_on_ray([(demos, 42)])
    with pytest.raises((DefenderError, OSError), match="nonexistent"):
        ablate_on_ray([(demos, "/nonexistent/episodes.npz")])
