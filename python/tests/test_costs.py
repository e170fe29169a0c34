"""DTW and the costs of SPEC sections 2-4 on numpy arrays, and the offline ablation (section 7)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderError, EpisodeSet

from conftest import HOPPER_DEMOS


def naive_dtw(x, y):
    x, y = np.asarray(x, float).reshape(len(x), -1), np.asarray(y, float).reshape(len(y), -1)
    n, m = len(x), len(y)
    d = np.full((n + 1, m + 1), np.inf)
    d[0, 0] = 0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            d[i, j] = np.linalg.norm(x[i - 1] - y[j - 1]) + min(d[i - 1, j], d[i, j - 1], d[i - 1, j - 1])
    return d[n, m]


def test_dtw_matches_the_definition():
    rng = np.random.default_rng(0)
    for n, m, dim in [(1, 1, 1), (5, 9, 3), (17, 4, 11)]:
        x, y = rng.normal(size=(n, dim)), rng.normal(size=(m, dim))
        assert defender_rl.dtw(x, y) == pytest.approx(naive_dtw(x, y), rel=1e-5)
    assert defender_rl.dtw([0.0, 1.0, 2.0], [0.0, 2.0]) == pytest.approx(1.0)
    with pytest.raises(DefenderError, match="same number of columns"):
        defender_rl.dtw(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(DefenderError, match="not finite"):
        defender_rl.dtw([0.0, np.nan], [1.0])
    with pytest.raises(DefenderError, match="at least one row"):
        defender_rl.dtw(np.zeros((0, 2)), np.zeros((3, 2)))


def test_windows_and_groups():
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=(12, 2)), rng.normal(size=(20, 2))
    assert defender_rl.window_cost(x, y, "Both") == pytest.approx(naive_dtw(x, y), rel=1e-5)
    assert defender_rl.window_cost(x, y, "TrajW5") == pytest.approx(naive_dtw(x[-5:], y), rel=1e-5)
    assert defender_rl.window_cost(x, y, "DemoW10") == pytest.approx(naive_dtw(x, y[-10:]), rel=1e-5)
    assert defender_rl.window_cost(x, y, "BothW5") == pytest.approx(naive_dtw(x[-5:], y[-5:]), rel=1e-5)
    assert defender_rl.window_cost(x, y, "Equal") == pytest.approx(naive_dtw(x, y[-12:]), rel=1e-5)
    group = [rng.normal(size=(k, 2)) for k in (3, 8, 15)]
    value, costs = defender_rl.group_cost(x, group, "MaxDemoW5")
    assert costs == pytest.approx([naive_dtw(x, g[-5:]) for g in group], rel=1e-5)
    assert value == pytest.approx(max(costs))
    with pytest.raises(DefenderError, match="window: unknown window"):
        defender_rl.window_cost(x, y, "W5")
    with pytest.raises(DefenderError, match="method: unknown method"):
        defender_rl.group_cost(x, group, "MedianBoth")


def test_trajectory_costs_are_the_online_filters_and_match_group_cost():
    demos = EpisodeSet.load(HOPPER_DEMOS).select_demos(5)
    ep = demos.episode(0)
    obs, act = ep["obs"][:-1][:30], ep["act"][:30]
    out = defender_rl.trajectory_costs(demos, obs, act, "MeanDemoW5/MinBothW10")
    assert out["safe_cost"].shape == (30,) and out["filtered"].dtype == bool
    arrays = [demos.episode(i) for i in range(len(demos))]
    safe = [e["obs"] for e in arrays if not e["crashed"]]
    unsafe = [e["obs"] for e in arrays if e["crashed"]]
    for t in (0, 4, 17, 29):
        s, _ = defender_rl.group_cost(obs[: t + 1], safe, "MeanDemoW5")
        u, _ = defender_rl.group_cost(obs[: t + 1], unsafe, "MinBothW10")
        assert out["safe_cost"][t] == pytest.approx(s, rel=1e-5)
        assert out["unsafe_cost"][t] == pytest.approx(u, rel=1e-5)
        assert out["filtered"][t] == (not out["safe_cost"][t] < out["unsafe_cost"][t])
    with pytest.raises(DefenderError, match="obs: expected 11 columns"):
        defender_rl.trajectory_costs(demos, obs[:, :3], act)


def test_ablate_ranks_strategies_and_releases_the_gil():
    demos = EpisodeSet.load(HOPPER_DEMOS).select_demos(4)
    episodes = EpisodeSet.load(HOPPER_DEMOS)
    rows = defender_rl.ablate(demos, episodes, strategies=["MeanDemoW5/MeanDemoW10", "MinBoth/MinBoth"])
    assert [r["rank"] for r in rows] == [1, 2]
    assert rows[0]["score"] >= rows[1]["score"]
    for r in rows:
        assert r["score"] == pytest.approx(r["mean_ratio"] * r["safe_rate"])
        assert r["strategy"] == f"{r['safe']}/{r['unsafe']}" and r["mode"] == "state"
    table = defender_rl.ablate(demos, episodes, strategies=["MinBoth/MinBoth", "MeanDemoW5/MeanDemoW10"], as_numpy=True)
    assert list(table["strategy"]) == [r["strategy"] for r in rows]
    np.testing.assert_allclose(table["score"], [r["score"] for r in rows])
    assert len(defender_rl.strategies()) == 576

    # While the full ablation (576 strategies) runs in a thread, Python keeps running here.
    ticks = 0
    result = {}
    thread = threading.Thread(target=lambda: result.setdefault("rows", defender_rl.ablate(demos, episodes.select_demos(3))))
    thread.start()
    while thread.is_alive():
        ticks += 1
        time.sleep(0.001)
    thread.join()
    assert len(result["rows"]) == 576
    assert ticks > 5, "the main thread did not run while ablate worked: is the GIL released?"
    with pytest.raises(DefenderError, match="strategies"):
        defender_rl.ablate(demos, episodes, strategies=["Nope/MinBoth"])
    with pytest.raises(DefenderError, match="mode"):
        defender_rl.ablate(demos, episodes, mode="both")


def test_derive_seed_is_the_rust_one():
    assert defender_rl.derive_seed(0, "demonstration", 1) != defender_rl.derive_seed(0, "demonstration", 2)
    with pytest.raises(DefenderError, match="purpose"):
        defender_rl.derive_seed(0, "nope", 1)
