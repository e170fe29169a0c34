"""DefenderWrapper: Gymnasium's check_env, the semantics of SPEC sections 4-6 as seen from
Python, state save/restore, vector environments, and errors for bad input."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import defender_rl
from defender_rl import DefenderError, DefenderWrapper, EpisodeSet, ResetNeeded

from conftest import HOPPER_DEMOS, DriftEnv


def test_is_a_gymnasium_wrapper_and_passes_check_env():
    env = DefenderWrapper(gym.make("Hopper-v5"), HOPPER_DEMOS, seed=0)
    assert isinstance(env, gym.Env) and isinstance(env, gym.Wrapper)
    check_env(env, skip_render_check=True)
    check_env(DefenderWrapper(gym.make("DefenderTest/Drift-v0"), defender_rl_drift(), seed=0), skip_render_check=True)
    env.close()


def defender_rl_drift():
    from conftest import drift_demos

    return drift_demos()


def run_episode(env, policy, seed):
    obs, info = env.reset(seed=seed)
    steps = []
    while True:
        action = policy(obs)
        out = env.step(action)
        steps.append(out)
        if out[2] or out[3]:
            return steps
        obs = out[0]


def test_filtered_step_is_not_executed_and_returns_the_prediction(drift_set):
    inner = DriftEnv()
    # SPEC's decision rule (Safe >= Unsafe filters), checked below step by step.
    env = DefenderWrapper(inner, drift_set, "MinBoth/MinBoth", seed=1, profile="spec")
    assert env.r_task == pytest.approx(float(drift_set.min_reward))
    saw_filtered = saw_executed = False
    for ep in range(20):
        real_before = inner.real_steps
        obs, _ = env.reset(seed=ep)
        for t in range(200):
            action = np.array([1.0], dtype=np.float32)  # full throttle: looks like the unsafe group
            prev = obs
            obs, reward, terminated, truncated, info = env.step(action)
            assert set(info) >= {"defender_filtered", "defender_safe_cost", "defender_unsafe_cost"}
            filtered, safe, unsafe = env.last_decision
            assert info["defender_filtered"] == filtered
            assert info["defender_safe_cost"] == safe and info["defender_unsafe_cost"] == unsafe
            assert filtered == (not safe < unsafe)
            if filtered:
                saw_filtered = True
                # SPEC section 5: no real step, the model's prediction, R_task, terminated.
                assert inner.real_steps == real_before + t
                assert reward == env.r_task and terminated and not truncated
                assert obs.dtype == env.observation_space.dtype and obs.shape == (2,)
                np.testing.assert_allclose(obs, env.predict(prev, action), rtol=0, atol=0)
                assert info["defender_outcome"] == "filtered" and "inner_key" not in info
                assert env.last_outcome == "filtered"
                break
            saw_executed = True
            assert info["inner_key"] == t + 1  # the inner env's info is kept
            if terminated:
                assert info["defender_outcome"] == "crashed"
                break
    assert saw_filtered and saw_executed
    stats = env.defender_stats
    assert stats["episodes"] == 20
    assert stats["filtered_episodes"] + stats["crashed_episodes"] + stats["truncated_episodes"] == 20
    assert stats["steps"] == stats["filtered_steps"] + stats["real_steps"]
    assert stats["real_steps"] == inner.real_steps
    assert env.dynamics_info["real_steps"] == inner.real_steps


def test_safe_policy_is_not_filtered_and_truncates(drift_set):
    env = DefenderWrapper(gym.make("DefenderTest/Drift-v0"), drift_set, "MinBoth/MinBoth", seed=0)
    steps = run_episode(env, lambda o: np.array([np.clip(-3 * o[0] - 2 * o[1], -1, 1)], dtype=np.float32), 3)
    assert not any(s[4]["defender_filtered"] for s in steps[:20])
    assert steps[-1][4]["defender_outcome"] in ("truncated", "filtered")


def test_save_and_load_state(tmp_path, drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=3)
    rng = np.random.default_rng(0)
    for ep in range(5):
        run_episode(env, lambda o: rng.uniform(-1, 1, size=1).astype(np.float32), ep)
    env.save_state(tmp_path / "defender")
    probe = (np.array([0.1, 0.2]), np.array([0.5]))
    before, stats = env.predict(*probe), env.defender_stats
    other = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=99)
    assert not np.array_equal(other.predict(*probe), before)
    other.load_state(tmp_path / "defender")
    np.testing.assert_array_equal(other.predict(*probe), before)
    assert other.defender_stats == stats
    with pytest.raises(DefenderError, match="not an empty folder"):
        env.save_state(tmp_path / "defender")


def test_background_dynamics_gives_the_same_run(drift_set):
    outs = []
    for background in (False, True):
        env = DefenderWrapper(DriftEnv(), drift_set, "MeanBoth/MeanBoth", seed=5, dynamics={"background": background})
        rng = np.random.default_rng(1)
        trace = []
        for ep in range(8):
            for s in run_episode(env, lambda o: rng.uniform(-1, 1, size=1).astype(np.float32), ep):
                trace.append((s[0].tolist(), s[1], s[4]["defender_filtered"]))
        outs.append(trace)
    assert outs[0] == outs[1]


def make_hopper(seed):
    demos = EpisodeSet.load(HOPPER_DEMOS)

    def thunk():
        return DefenderWrapper(gym.make("Hopper-v5"), demos, "MeanDemoW5/MeanDemoW10", seed=seed)

    return thunk


def test_async_vector_env_pickles_the_arguments():
    # The env functions (and the EpisodeSet they hold) are pickled into the worker processes.
    pickle.dumps(EpisodeSet.load(HOPPER_DEMOS))
    envs = gym.vector.AsyncVectorEnv([make_hopper(0), make_hopper(1)])
    try:
        obs, _ = envs.reset(seed=0)
        assert obs.shape == (2, 11)
        seen = set()
        envs.action_space.seed(0)
        resetting = np.zeros(2, dtype=bool)  # next-step autoreset: this step only resets them
        for _ in range(60):
            obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
            assert info["defender_filtered"].shape == (2,)
            assert np.all(np.isfinite(info["defender_safe_cost"][~resetting]))
            assert np.all(np.isnan(info["defender_safe_cost"][resetting]))  # reset's neutral value
            resetting = term | trunc
            if "defender_outcome" in info:
                seen.update(o for o, m in zip(info["defender_outcome"], info["_defender_outcome"]) if m)
        assert seen, "no episode ended in 60 steps of random actions on Hopper-v5"
        assert seen <= {"crashed", "filtered", "truncated"}
    finally:
        envs.close()


# -- bad input -------------------------------------------------------------------------------


def test_unknown_strategy_and_mode(drift_set):
    with pytest.raises(DefenderError, match="strategy: .*MeanDemoW7.*valid forms"):
        DefenderWrapper(DriftEnv(), drift_set, "MeanDemoW7/MinBoth")
    with pytest.raises(DefenderError, match="strategy"):
        DefenderWrapper(DriftEnv(), drift_set, "MeanDemoW5")
    with pytest.raises(DefenderError, match="mode"):
        DefenderWrapper(DriftEnv(), drift_set, mode="actions")
    with pytest.raises(DefenderError, match="scaling: unknown 'minmax'"):
        DefenderWrapper(DriftEnv(), drift_set, scaling="minmax")
    with pytest.raises(DefenderError, match="scaling"):
        defender_rl.select(drift_set, scaling="z")
    with pytest.raises(DefenderError, match="dynamics: unknown field `hiden`"):
        DefenderWrapper(DriftEnv(), drift_set, dynamics={"hiden": [8]})
    with pytest.raises(DefenderError, match="r_task"):
        DefenderWrapper(DriftEnv(), drift_set, r_task=float("nan"))
    with pytest.raises(DefenderError, match="num_demos"):
        DefenderWrapper(DriftEnv(), drift_set, num_demos=0)
    with pytest.raises(DefenderError, match="num_demos asks for 9 demonstrations per group"):
        DefenderWrapper(DriftEnv(), drift_set, num_demos=9)


def test_non_box_spaces_are_refused(drift_set):
    with pytest.raises(TypeError, match="Box action space.*Discrete"):
        DefenderWrapper(gym.make("CartPole-v1"), drift_set)
    env = DriftEnv()
    env.observation_space = gym.spaces.Box(-1, 1, shape=(2, 2))
    with pytest.raises(TypeError, match="1-D Box observation space"):
        DefenderWrapper(env, drift_set)
    with pytest.raises(TypeError, match="wraps a gymnasium.Env"):
        DefenderWrapper("Hopper-v5", drift_set)


def test_demonstrations_that_do_not_fit(drift_set):
    with pytest.raises(DefenderError, match="'obs'.*11 columns.*got 2 columns"):
        DefenderWrapper(gym.make("Hopper-v5"), drift_set)
    with pytest.raises(OSError, match="no-such.npz"):
        DefenderWrapper(DriftEnv(), "no-such.npz")
    with pytest.raises(TypeError, match="demos: expected an EpisodeSet, a path"):
        DefenderWrapper(DriftEnv(), 42)
    only_safe = EpisodeSet.from_episodes([drift_set.episode(0)], env_id="DefenderTest/Drift-v0")
    with pytest.raises(DefenderError, match="unsafe"):
        DefenderWrapper(DriftEnv(), only_safe)


def test_bad_actions_and_call_order(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, seed=0)
    with pytest.raises(ResetNeeded, match="call reset"):
        env.step(np.zeros(1, dtype=np.float32))
    env.reset(seed=0)
    with pytest.raises(DefenderError, match=r"action.*1 values.*shape \(2,\)"):
        env.step(np.zeros(2))
    with pytest.raises(DefenderError, match=r"action.*shape \(1, 1\)"):
        env.step(np.zeros((1, 1)))
    with pytest.raises(DefenderError, match=r"element 0 of the action is NaN at step 1"):
        env.step(np.array([np.nan]))
    with pytest.raises(DefenderError, match="cannot be read"):
        env.step("left")
    # After those errors the episode goes on.
    out = env.step(np.array([0.0], dtype=np.float32))
    assert len(out) == 5
    with pytest.raises(ValueError, match="non-negative integer"):
        env.reset(seed=-1)
    env.close()
    with pytest.raises(RuntimeError, match="closed"):
        env.reset()
    with pytest.raises(RuntimeError, match="closed"):
        env.step(np.zeros(1, dtype=np.float32))


class Broken(DriftEnv):
    def __init__(self, mode):
        super().__init__()
        self.mode = mode

    def step(self, action):
        if self.mode == "raise":
            raise KeyError("inner failure")
        if self.mode == "shape":
            return np.zeros(3), 0.0, False, False, {}
        if self.mode == "nan":
            return np.array([np.nan, 0.0]), 0.0, False, False, {}
        return (np.zeros(2), 0.0)


@pytest.mark.parametrize(
    "mode, exc, pattern",
    [
        ("raise", KeyError, "inner failure"),
        ("shape", DefenderError, "observation returned by the wrapped environment's step.*2 values"),
        ("tuple", TypeError, r"must return a tuple \(obs, reward, terminated, truncated, info\)"),
    ],
)
def test_errors_of_the_wrapped_env_reach_the_caller(drift_set, mode, exc, pattern):
    env = DefenderWrapper(Broken(mode), drift_set, "MaxBoth/MinBoth", seed=0)
    env.reset(seed=0)
    with pytest.raises(exc, match=pattern):
        env.step(np.zeros(1, dtype=np.float32))


def test_nan_observation_of_the_wrapped_env_is_an_error(drift_set):
    env = DefenderWrapper(Broken("nan"), drift_set, "MaxBoth/MinBoth", seed=0)
    env.reset(seed=0)
    with pytest.raises(DefenderError, match=r"step\(\) returned an observation whose element 0 is NaN at step 1"):
        env.step(np.zeros(1, dtype=np.float32))
