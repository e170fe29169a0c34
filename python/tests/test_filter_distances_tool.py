"""tools/analysis/filter_distances.py replays recorded episodes against the demonstrations: its Safe and
Unsafe must be the values the Rust filter computed online, z-scored and with the episodes that
joined the groups as they ended."""

from __future__ import annotations

import csv
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from conftest import ROOT, DriftEnv

TOOL = ROOT / "tools" / "analysis" / "filter_distances.py"


def run_tool(tmp_path, demos, episodes, *extra):
    out = tmp_path / "distances.csv"
    subprocess.run([sys.executable, str(TOOL), "--demos", str(demos), "--episodes", str(episodes),
                    "--out", str(out), *extra], check=True, capture_output=True, text=True)
    with open(out, newline="") as f:
        return list(csv.DictReader(f))


def record(wrapper, policies):
    """One episode per policy through the wrapper: the episodes as `--record-episodes` keeps them
    (crashed = the environment ended it), and the filter's costs at every step."""
    episodes, costs = [], []
    for k, policy in enumerate(policies):
        obs, _ = wrapper.reset(seed=k)
        obs_l, act_l, rew_l, safe, unsafe = [obs], [], [], [], []
        while True:
            a = np.array([policy(obs)], dtype=np.float32)
            obs, r, term, trunc, info = wrapper.step(a)
            obs_l.append(obs)
            act_l.append(a)
            rew_l.append(r)
            safe.append(info["defender_safe_cost"])
            unsafe.append(info["defender_unsafe_cost"])
            if term or trunc:
                break
        crashed = info["defender_outcome"] == "crashed"
        episodes.append((np.array(obs_l), np.array(act_l), np.array(rew_l), crashed))
        costs.append((np.array(safe), np.array(unsafe)))
    return episodes, costs


def hold(obs):
    return float(np.clip(-3 * obs[0] - 2 * obs[1], -1, 1))


def throttle(obs):
    return 0.8


@pytest.mark.parametrize("scaling", ["none", "zscore"])
def test_tool_gives_the_online_filters_costs_with_own_episodes(tmp_path, drift_set, scaling):
    demos = tmp_path / "demos.npz"
    drift_set.save(demos)
    wrapper = defender_rl.DefenderWrapper(
        gym.wrappers.TimeLimit(DriftEnv(), max_episode_steps=30), drift_set, strategy="MeanBoth/MeanBoth", scaling=scaling, seed=0,
        profile="spec", filter={"own_episodes": {"keep": 1}, "margin": 0.99},  # rarely filters: every episode runs out
    )
    episodes, costs = record(wrapper, [throttle, hold, throttle, hold])
    assert [e[3] for e in episodes] == [True, False, True, False]  # both groups get own episodes
    recorded = tmp_path / "episodes.npz"
    defender_rl.EpisodeSet.from_episodes(episodes, env_id="DefenderTest/Drift-v0").save(recorded)

    per_episode = tmp_path / "per-episode.csv"
    rows = run_tool(tmp_path, demos, recorded, "--strategy", "MeanBoth/MeanBoth", "--scaling", scaling,
                    "--own-episodes", "1", "--margin", "0.5", "--per-episode", str(per_episode))
    for e, (safe, unsafe) in enumerate(costs):
        mine = [r for r in rows if int(r["episode"]) == e]
        assert [int(r["step"]) for r in mine] == list(range(len(safe)))
        np.testing.assert_allclose([float(r["safe"]) for r in mine], safe, rtol=1e-4)
        np.testing.assert_allclose([float(r["unsafe"]) for r in mine], unsafe, rtol=1e-4)

    with open(per_episode, newline="") as f:
        summary = list(csv.DictReader(f))
    assert [r["label"] for r in summary] == ["unsafe", "safe", "unsafe", "safe"]
    for e, (safe, unsafe) in enumerate(costs):
        ratio = unsafe / safe
        assert float(summary[e]["min_ratio"]) == pytest.approx(ratio.min(), rel=1e-3)
        assert int(summary[e]["min_ratio_step"]) == int(np.argmin(ratio))
        fired = np.flatnonzero(ratio <= 0.5)
        assert int(summary[e]["first_filtered_step"]) == (int(fired[0]) if len(fired) else -1)

    # Without --own-episodes the groups are the file's alone: later episodes differ.
    alone = run_tool(tmp_path, demos, recorded, "--strategy", "MeanBoth/MeanBoth", "--scaling", scaling)
    assert len(alone) == len(rows)
    assert any(a["unsafe"] != b["unsafe"] for a, b in zip(alone, rows) if int(a["episode"]) >= 1)

    # --every thins the rows, not the per-episode table's count of steps replayed.
    thinned = run_tool(tmp_path, demos, recorded, "--strategy", "MeanBoth/MeanBoth", "--scaling", scaling,
                       "--every", "4", "--per-episode", str(per_episode))
    assert len(thinned) < len(rows)
    with open(per_episode, newline="") as f:
        assert [int(r["steps"]) for r in csv.DictReader(f)] == [len(safe) for safe, _ in costs]


def test_tool_refuses_a_bad_strategy(tmp_path, drift_set):
    demos = tmp_path / "demos.npz"
    drift_set.save(demos)
    out = subprocess.run([sys.executable, str(TOOL), "--demos", str(demos), "--episodes", str(demos),
                          "--strategy", "MedianBoth/MinBoth", "--out", str(tmp_path / "x.csv")],
                         capture_output=True, text=True)
    assert out.returncode != 0 and "MedianBoth" in out.stderr
    assert not (tmp_path / "x.csv").exists()
