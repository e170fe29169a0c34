"""The opt-in Stable-Baselines3 tier (`make test-sb3`; PyTorch from PyPI): SAC with and without
DEFENDER on Gymnasium's InvertedDoublePendulum-v5 for a short budget, and the callback's logging."""

from __future__ import annotations

import csv
import pathlib

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import SAC
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from stable_baselines3.common.logger import configure
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import SubprocVecEnv

from defender_rl import DefenderWrapper, EpisodeSet
from defender_rl.sb3 import DefenderCallback, DemoCollectorCallback
from defender_rl.demos import DemoRecorder

ROOT = pathlib.Path(__file__).resolve().parents[2]
IDP = "InvertedDoublePendulum-v5"
IDP_DEMOS = ROOT / "data" / "demos" / f"{IDP}.npz"
STEPS = 4000


def crash_rate_bare(steps: int) -> float:
    env = Monitor(gym.make(IDP))
    SAC("MlpPolicy", env, seed=0, learning_starts=100).learn(steps)
    lengths = env.get_episode_lengths()
    return sum(n < env.spec.max_episode_steps for n in lengths) / len(lengths)


def test_sac_with_defender_crashes_less_on_inverted_double_pendulum(tmp_path):
    bare = crash_rate_bare(STEPS)
    env = Monitor(DefenderWrapper(gym.make(IDP), IDP_DEMOS, "MinDemoW5/MinDemoW10", seed=0),
                  info_keywords=("defender_outcome",))
    model = SAC("MlpPolicy", env, seed=0, learning_starts=100)
    model.set_logger(configure(str(tmp_path), ["csv"]))
    callback = DefenderCallback()
    model.learn(STEPS, callback=callback, log_interval=5)
    stats = env.env.defender_stats
    defended = stats["crashed_episodes"] / stats["episodes"]
    print(f"{IDP} SAC {STEPS} steps: crash rate bare {bare:.3f}, with DEFENDER {defended:.3f}")
    assert defended < bare
    assert callback.crash_rate == pytest.approx(defended)
    rows = list(csv.DictReader(open(tmp_path / "progress.csv")))
    assert "defender/crash_rate" in rows[-1] and "defender/filter_rate" in rows[-1]
    for key in ("defender/dynamics_error", "defender/mean_safe_cost", "defender/mean_unsafe_cost", "defender/r_task"):
        assert any(row.get(key) for row in rows), key
    # Monitor carried the outcome of every episode.
    assert set(env.get_episode_lengths()) and "defender_outcome" in env.info_keywords


def test_sb3_check_env_and_subproc_vec_env():
    demos = EpisodeSet.load(IDP_DEMOS)
    sb3_check_env(DefenderWrapper(gym.make(IDP), demos, seed=0))
    make = lambda s: (lambda: DefenderWrapper(gym.make(IDP), demos, "MinDemoW5/MinDemoW10", seed=s))  # noqa: E731
    venv = SubprocVecEnv([make(0), make(1)])
    try:
        stats = venv.get_attr("defender_stats")
        assert len(stats) == 2 and stats[0]["steps"] == 0
        model = SAC("MlpPolicy", venv, seed=0, learning_starts=50)
        callback = DefenderCallback()
        model.learn(300, callback=callback)
        assert sum(callback.counts.values()) > 0
    finally:
        venv.close()


def test_demo_collector_callback_records_after_learning_starts_and_stops():
    recorder = DemoRecorder(IDP, seed=0)
    model = SAC("MlpPolicy", gym.make(IDP), seed=0, learning_starts=200)
    model.learn(3000, callback=DemoCollectorCallback(recorder, 0, 3))
    # Stopped once 3 unsafe candidates were recorded, all after SAC's random steps.
    assert recorder.group_sizes[1] >= 3 and model.num_timesteps < 3000
    assert all(k >= 0 for k in recorder.sources)


def test_monitor_inside_the_wrapper_warns_and_make_vec_env_the_right_way_does_not(monkeypatch):
    import warnings

    import defender_rl.wrapper
    from stable_baselines3.common.env_util import make_vec_env

    monkeypatch.setattr(defender_rl.wrapper, "_warned_statistics", set())
    with pytest.warns(UserWarning, match=r"Monitor\(DefenderWrapper\(env, \.\.\.\)\)"):
        make_vec_env(IDP, n_envs=1, wrapper_class=DefenderWrapper, wrapper_kwargs={"demos": IDP_DEMOS}).close()
    monkeypatch.setattr(defender_rl.wrapper, "_warned_statistics", set())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        venv = make_vec_env(lambda: DefenderWrapper(gym.make(IDP), IDP_DEMOS), n_envs=2)
    model = SAC("MlpPolicy", venv, seed=0, learning_starts=5000)
    with pytest.warns(UserWarning, match="learning_starts = 5000 is at or beyond total_timesteps = 200"):
        model.learn(200, callback=DefenderCallback())
    venv.close()
