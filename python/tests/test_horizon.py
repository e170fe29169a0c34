"""Demonstration horizons: a safe demonstration reached the task's horizon (the
``max_episode_steps`` Gymnasium registers); an episode cut earlier by a shorter time limit is not
kept as safe by DemoRecorder or from_minari (one warning, with the count and lengths), unless the
user gives a rule; the wrapper warns when a set's safe episodes end before the horizon."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderWrapper, DemoRecorder, EpisodeSet
from defender_rl.horizon import task_horizon

from conftest import DriftEnv


def hold(obs):
    return np.array([np.clip(-3 * obs[0] - 2 * obs[1], -1, 1)], dtype=np.float32)


def test_the_task_horizon_is_the_registered_one():
    assert task_horizon("DefenderTest/Drift-v0") == 100
    assert task_horizon("Hopper-v5") == 1000
    assert task_horizon(None, 40) == 40 and task_horizon("no-such-task-v0", 40) == 40
    short = gym.make("DefenderTest/Drift-v0", max_episode_steps=40)
    assert DemoRecorder(short).horizon == 100  # the task's, not this make's


def test_recorder_leaves_out_episodes_cut_before_the_horizon():
    rec = DemoRecorder(gym.make("DefenderTest/Drift-v0", max_episode_steps=40), seed=0)
    with pytest.warns(UserWarning, match=r"ended after 40 steps without terminating, before the task's horizon of 100"):
        assert rec.record(hold) is False
    rec.record(hold)
    assert rec.group_sizes == (0, 0) and rec.left_out == [40, 40]
    assert rec.record(lambda o: np.array([1.0], dtype=np.float32)) is True
    # The user's rule: 40 steps are enough.
    rec = DemoRecorder(gym.make("DefenderTest/Drift-v0", max_episode_steps=40), horizon=40)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec.record(hold)
    assert rec.group_sizes == (1, 0)
    # The whole horizon is safe.
    full = DemoRecorder("DefenderTest/Drift-v0")
    full.record(hold)
    assert full.group_sizes == (1, 0) and len(full.candidates[0][2]) == 100


def short_set(safe_len: int) -> EpisodeSet:
    env = DriftEnv()
    episodes = []
    for crashed, n in ((False, safe_len), (True, 200)):
        for seed in range(2):
            obs, _ = env.reset(seed=seed)
            obs_l, act_l, rew_l = [obs], [], []
            for _ in range(n):
                a = hold(obs) if not crashed else np.array([1.0], dtype=np.float32)
                obs, r, term, _, _ = env.step(a)
                obs_l.append(obs), act_l.append(a), rew_l.append(r)
                if term:
                    break
            episodes.append((np.array(obs_l), np.array(act_l, dtype=np.float64), np.array(rew_l), crashed))
    return EpisodeSet.from_episodes(episodes, env_id="DefenderTest/Drift-v0")


def test_the_wrapper_warns_when_safe_demonstrations_end_before_the_horizon(tmp_path):
    short = short_set(40)
    with pytest.warns(UserWarning, match=r"2 safe demonstration\(s\) end before the task's horizon of 100 steps \(lengths 40, 40\)"):
        DefenderWrapper(gym.make("DefenderTest/Drift-v0"), short, "MinBoth/MinBoth")
    short.save(tmp_path / "short.npz")
    with pytest.warns(UserWarning, match="2 safe demonstration"):
        DefenderWrapper(gym.make("DefenderTest/Drift-v0"), tmp_path / "short.npz", "MinBoth/MinBoth")
    with pytest.warns(UserWarning, match=r"1 safe demonstration\(s\).*lengths 40\)"):
        DefenderWrapper(gym.make("DefenderTest/Drift-v0"), short, "MinBoth/MinBoth", num_demos=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        DefenderWrapper(gym.make("DefenderTest/Drift-v0"), short_set(100), "MinBoth/MinBoth")


def test_from_minari_keeps_only_episodes_that_reached_the_horizon_as_safe(tmp_path, monkeypatch):
    minari = pytest.importorskip("minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    env = minari.DataCollector(gym.make("DefenderTest/Drift-v0", max_episode_steps=40))
    for ep in range(6):
        obs, _ = env.reset(seed=ep)
        while True:
            a = np.array([1.0], dtype=np.float32) if ep % 2 else hold(obs)
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                break
    dataset = env.create_dataset(dataset_id="defendertest/drift-short-v0", algorithm_name="scripted")
    env.close()
    with pytest.warns(UserWarning, match=r"left out 3 episode\(s\) that neither terminated nor reached the task's horizon of 100 steps \(lengths 40, 40, 40\)"):
        s = defender_rl.from_minari(dataset)
    assert s.group_sizes == (0, 3)
    assert "100 steps" in s.meta["safe_rule"]
    # A rule of the user's keeps them.
    s = defender_rl.from_minari(dataset, horizon=40)
    assert s.group_sizes == (3, 3)
    s = defender_rl.from_minari(dataset, crashed=lambda ep: bool(ep.terminations[-1]))
    assert s.group_sizes == (3, 3)
