"""tools/navigation/navigation_features.py and the state rule of tools/navigation/navigation_summary.py on hand-made
episode sets (docs/results-navigation.md, "Why"): the copy keeps the chosen features, the labels
and the limit; the rule fires where the largest hazards-lidar bin passes the hazard's radius."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from conftest import ROOT
from defender_rl import EpisodeSet

sys.path.insert(0, str(ROOT / "tools" / "navigation"))
import navigation_summary  # noqa: E402

INSIDE = navigation_summary.INSIDE  # 1 - 0.2 / 3


def episode(n: int, unsafe: bool, near_from: int | None, d: int = 6) -> tuple:
    """n transitions; columns 2..4 play the hazards lidar: low, then above INSIDE from step
    near_from (in column 3 only, as one bin would read a hazard ahead)."""
    obs = np.full((n + 1, d), 0.1)
    obs[:, 0] = np.arange(n + 1)
    if near_from is not None:
        obs[near_from:, 3] = 0.95
    return obs, np.zeros((n, 1)), np.ones(n), unsafe


def save(path, episodes):
    EpisodeSet.from_episodes(episodes, env_id="SafetyPointGoal1-v0", meta={"episode_cost_limit": 25.0}).save(str(path))


def test_features_keep_columns_or_their_largest(tmp_path):
    src = tmp_path / "in.npz"
    save(src, [episode(30, True, 10), episode(40, False, None)])
    for flag, dim in (("--columns", 3), ("--max-of", 1)):
        out = tmp_path / f"{flag[2:]}.npz"
        subprocess.run([sys.executable, str(ROOT / "tools" / "navigation" / "navigation_features.py"), flag, "2:5",
                        "--in", str(src), "--out", str(out)], check=True, capture_output=True, text=True)
        got = EpisodeSet.load(str(out))
        assert got.meta["obs_dim"] == dim and got.meta["episode_cost_limit"] == 25.0
        assert got.group_sizes == (1, 1) and "2:5" in got.meta["features"]
        first = got.episode(0)["obs"]
        assert first.shape == (31, dim)
        if dim == 1:
            np.testing.assert_allclose(first[:, 0], [0.1] * 10 + [0.95] * 21, rtol=1e-6)
        else:
            np.testing.assert_allclose(first[12], [0.1, 0.95, 0.1], rtol=1e-6)
    bad = subprocess.run([sys.executable, str(ROOT / "tools" / "navigation" / "navigation_features.py"), "--columns", "4:9",
                          "--in", str(src), "--out", str(tmp_path / "x.npz")], capture_output=True, text=True)
    assert bad.returncode != 0 and "beyond obs_dim 6" in bad.stderr


def test_the_inside_rule_counts_as_the_screen_does(tmp_path):
    path = tmp_path / "episodes.npz"
    save(path, [
        episode(30, True, 10),     # caught: inside from s_10, violation on step 29: lead 30 - 10
        episode(30, True, 30),     # inside only at the final observation: too late, not caught
        episode(50, False, 45),    # a safe episode that touched a hazard: a false alarm
        episode(50, False, None),  # never near: kept
    ])
    got = navigation_summary.inside_rule(str(path), slice(2, 5))
    assert got["unsafe"] == 2 and got["safe"] == 2
    assert (got["caught_pct"], got["false_alarm_pct"], got["mean_lead"]) == (50.0, 50.0, 20.0)
    assert 0.93 < got["threshold"] < 0.934
