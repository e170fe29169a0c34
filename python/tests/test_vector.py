"""DefenderWrapper under Gymnasium's vector environments: every per-step key is in ``info`` on
every step, whatever the autoreset mode, also on a step where every sub-environment resets
(reset's ``info`` carries them with neutral values); and the one-time warning for episode
statistics recorded inside the wrapper."""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderWrapper
from defender_rl.wrapper import RESET_INFO

from conftest import DriftEnv, drift_demos

PER_STEP = ("cost", "defender_filtered", "defender_safe_cost", "defender_unsafe_cost")


def make_drift(seed: int):
    demos = drift_demos()

    def thunk():
        return DefenderWrapper(gym.make("DefenderTest/Drift-v0"), demos, "MinBoth/MinBoth", seed=seed)

    return thunk


def test_reset_info_has_every_per_step_key_with_neutral_values(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, seed=0)
    _, info = env.reset(seed=0)
    assert set(PER_STEP) <= set(info) and info["reset_info"] == 1
    assert info["defender_filtered"] is False
    assert math.isnan(info["defender_safe_cost"]) and math.isnan(info["defender_unsafe_cost"])
    assert set(RESET_INFO) == set(PER_STEP)


@pytest.mark.parametrize("vector", [gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv])
@pytest.mark.parametrize("mode", [gym.vector.AutoresetMode.NEXT_STEP, gym.vector.AutoresetMode.SAME_STEP])
def test_no_autoreset_mode_loses_a_key(vector, mode):
    # Two identical sub-environments with the same actions end their episodes on the same steps:
    # the step on which every one of them resets is the one that lost the keys.
    envs = vector([make_drift(0), make_drift(0)], autoreset_mode=mode)
    try:
        envs.reset(seed=[3, 3])
        all_reset_steps = episodes = 0
        rng = np.random.default_rng(0)
        for _ in range(300):
            action = np.repeat(rng.uniform(-1, 1, size=(1, 1)), 2, axis=0).astype(np.float32)
            _, _, term, trunc, info = envs.step(action)
            for key in PER_STEP:
                assert key in info, (key, mode)
                assert info[key].shape == (2,) and info["_" + key].all()
            done = term | trunc
            episodes += int(done.sum())
            if mode == gym.vector.AutoresetMode.NEXT_STEP and not np.isfinite(info["defender_safe_cost"]).any():
                all_reset_steps += 1  # a reset's neutral costs in every sub-environment
            if mode == gym.vector.AutoresetMode.SAME_STEP and done.all():
                all_reset_steps += 1
                assert "final_info" in info and "defender_outcome" in info["final_info"]
        assert episodes >= 4 and all_reset_steps >= 1, (episodes, all_reset_steps)
    finally:
        envs.close()


def test_make_vec_with_the_wrapper(drift_set):
    envs = gym.make_vec(
        "DefenderTest/Drift-v0", num_envs=3, vectorization_mode="sync",
        wrappers=[lambda e: DefenderWrapper(e, drift_set, "MinBoth/MinBoth", seed=0)],
    )
    envs.reset(seed=0)
    for _ in range(150):
        _, _, _, _, info = envs.step(envs.action_space.sample())
        assert info["defender_filtered"].shape == (3,)
    envs.close()


def test_statistics_inside_the_wrapper_warn_once_naming_the_order(drift_set, monkeypatch):
    monkeypatch.setattr(defender_rl.wrapper, "_warned_statistics", set())
    with pytest.warns(UserWarning, match=r"RecordEpisodeStatistics\(DefenderWrapper\(env, \.\.\.\)\)"):
        DefenderWrapper(gym.wrappers.RecordEpisodeStatistics(DriftEnv()), drift_set)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        DefenderWrapper(gym.wrappers.RecordEpisodeStatistics(DriftEnv()), drift_set)  # once
        # The right order does not warn.
        gym.wrappers.RecordEpisodeStatistics(DefenderWrapper(DriftEnv(), drift_set))


def test_a_built_wrapper_says_to_pickle_a_thunk(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set)
    with pytest.raises(pickle.PicklingError, match=r"does not pickle.*Pass a function that builds it"):
        pickle.dumps(env)
    import cloudpickle

    cloudpickle.dumps(make_drift(0))  # what vector environments send to their workers


def test_the_vector_example_writes_rates_to_tensorboard(tmp_path):
    import subprocess
    import sys

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from conftest import ROOT

    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "vector_defender.py"), "--env-id", "InvertedDoublePendulum-v5",
         "--num-envs", "3", "--total-timesteps", "600", "--strategy", "MinDemoW5/MinDemoW10",
         "--logdir", str(tmp_path)],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    (run,) = tmp_path.iterdir()
    acc = EventAccumulator(str(run))
    acc.Reload()
    tags = set(acc.Tags()["tensors"]) | set(acc.Tags()["scalars"])
    assert {"defender/crash_rate", "defender/filter_rate", "defender/filtered_step_rate"} <= tags, tags
