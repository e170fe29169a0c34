"""Cost-labelled demonstrations from Python (docs/SPEC.md, section 13): ``DemoRecorder`` and
``collect_demos`` with ``episode_cost_limit`` label and cut episodes as ``defender demos collect``
does on a cost task, and write its ``meta``; their reset seeds are 32-bit. The task is the drift
line of conftest.py with a cost this file supplies through ``info["cost"]`` (the real
Safety-Gymnasium tasks: python/tests_safety_gym, beside safety-gymnasium in its own venv)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from defender_rl import DefenderError, DefenderWrapper, DemoRecorder, EpisodeSet, collect_demos, derive_seed
from defender_rl.demos import fold32, reset_seed

from conftest import ROOT

HOLD = lambda obs: np.array([np.clip(-3 * obs[0] - 2 * obs[1], -1, 1)], dtype=np.float32)  # noqa: E731
THROTTLE = lambda obs: np.array([1.0], dtype=np.float32)  # noqa: E731  (|x| > 1 within ~30 steps)


class Cost(gym.Wrapper):
    """Puts ``costs(t)`` into step t's ``info["cost"]`` (t = 1, 2, ... within the episode) and
    keeps every episode's costs and reset seeds, to check the recorder against them."""

    def __init__(self, env: gym.Env, costs, key: str = "cost"):
        super().__init__(env)
        self.costs, self.key = costs, key
        self.episodes: list[list[float]] = []
        self.seeds: list[int] = []

    def reset(self, *, seed=None, options=None):
        self.episodes.append([])
        self.seeds.append(seed)
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        cost = self.costs(len(self.episodes[-1]) + 1)
        self.episodes[-1].append(cost)
        info[self.key] = cost
        return obs, reward, terminated, truncated, info


def drift(costs, **make) -> Cost:
    return Cost(gym.make("DefenderTest/Drift-v0", **make), costs)  # horizon 100 (registered)


def test_reset_seeds_are_the_derived_ones_folded_to_32_bits():
    assert fold32(0x1234_5678_9ABC_DEF0) == 0x1234_5678 ^ 0x9ABC_DEF0
    assert fold32(2**32 - 1) == 2**32 - 1
    seeds = [reset_seed(s, k) for s in (0, 1, 2**64 - 1) for k in range(50)]
    assert all(0 <= x < 2**32 for x in seeds) and len(set(seeds)) == len(seeds)
    assert reset_seed(3, 7) == fold32(derive_seed(3, "demonstration", 7))
    # What they replace was 64-bit: numpy's RandomState (Safety-Gymnasium's layouts) refuses it.
    assert any(derive_seed(0, "demonstration", k) >= 2**32 for k in range(5))
    env = drift(lambda t: 0.0)
    rec = DemoRecorder(env, seed=3, episode_cost_limit=25)
    rec.record(HOLD, after_episode=7)
    assert env.seeds == [reset_seed(3, 7)]
    np.random.RandomState(env.seeds[0])  # accepted


def test_an_episode_is_cut_on_the_step_that_passes_the_limit():
    # Cost 1 a step, limit 2.5: the third step passes it (3 > 2.5); the demonstration is the
    # episode up to and including that step, and the episode goes no further.
    env = drift(lambda t: 1.0)
    rec = DemoRecorder(env, episode_cost_limit=2.5)
    assert rec.record(HOLD) is True
    obs, act, rew, unsafe = rec.candidates[0]
    assert unsafe and (len(obs), len(act), len(rew)) == (4, 3, 3)
    assert env.episodes == [[1.0, 1.0, 1.0]]


def test_the_limit_is_strict_and_a_whole_episode_within_it_is_safe():
    # 0.25 a step over the 100-step horizon sums to exactly 25.0: not above 25, so safe.
    rec = DemoRecorder(drift(lambda t: 0.25), episode_cost_limit=25)
    assert rec.record(HOLD) is False
    assert rec.group_sizes == (1, 0) and len(rec.candidates[0][2]) == 100
    # One step more cost: passed on the last step.
    rec = DemoRecorder(drift(lambda t: 0.25 + (t == 100) * 1e-9), episode_cost_limit=25)
    assert rec.record(HOLD) is True and len(rec.candidates[0][2]) == 100


def test_a_fall_under_the_limit_is_of_neither_group_and_a_fall_past_it_is_unsafe():
    rec = DemoRecorder(drift(lambda t: 0.0), episode_cost_limit=25)
    with pytest.warns(UserWarning, match="neither unsafe nor safe"):
        assert rec.record(THROTTLE) is False
    assert rec.group_sizes == (0, 0) and len(rec.left_out) == 1
    # The crash rule would have kept it as unsafe: costs are not read there.
    crash = DemoRecorder(drift(lambda t: 0.0))
    assert crash.record(THROTTLE) is True and len(crash.candidates[0][2]) == rec.left_out[0]
    # Past the limit before the fall: unsafe, cut where it passed, not at the fall.
    rec = DemoRecorder(drift(lambda t: 10.0), episode_cost_limit=25)
    assert rec.record(THROTTLE) is True and len(rec.candidates[0][2]) == 3


def test_an_episode_cut_before_the_horizon_under_the_limit_is_left_out():
    rec = DemoRecorder(drift(lambda t: 0.0, max_episode_steps=40), episode_cost_limit=25)
    with pytest.warns(UserWarning, match="without passing the cost limit, before the task's horizon of 100"):
        rec.record(HOLD)
    assert rec.group_sizes == (0, 0) and rec.left_out == [40]
    rec = DemoRecorder(drift(lambda t: 0.0, max_episode_steps=40), episode_cost_limit=25, horizon=0)
    assert rec.record(HOLD) is False and rec.group_sizes == (1, 0)


def test_costs_and_limits_are_checked_by_name():
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(DefenderError, match="episode_cost_limit"):
            DemoRecorder(drift(lambda t: 0.0), episode_cost_limit=bad)
    with pytest.raises(TypeError, match="episode_cost_limit"):
        DemoRecorder(drift(lambda t: 0.0), episode_cost_limit="25")
    with pytest.raises(DefenderError, match=r"info has no 'cost'.*cost_key.*inner_key"):
        DemoRecorder("DefenderTest/Drift-v0", episode_cost_limit=25).record(HOLD)
    with pytest.raises(DefenderError, match="finite number >= 0"):
        DemoRecorder(drift(lambda t: -1.0), episode_cost_limit=25).record(HOLD)
    with pytest.raises(TypeError, match="not a number"):
        DemoRecorder(drift(lambda t: "1"), episode_cost_limit=25).record(HOLD)
    # Another key, numpy and bool costs, as DefenderWrapper takes them.
    env = Cost(gym.make("DefenderTest/Drift-v0"), lambda t: np.float32(1.0), key="cost_hazards")
    assert DemoRecorder(env, episode_cost_limit=1.5, cost_key="cost_hazards").record(HOLD) is True
    assert DemoRecorder(drift(lambda t: True), episode_cost_limit=1.5).record(HOLD) is True


def improving():
    """A "training" loop whose even episodes hold on at no cost and whose odd ones run into
    cost 1 a step; the recorder sees the policy of the last ``train(k)``."""
    state = {"k": 0}

    def train(k):
        state["k"] = k

    def policy(obs):
        return HOLD(obs)

    costs = lambda t: float(state["k"] % 2)  # noqa: E731
    return train, policy, costs


def test_collect_demos_writes_the_meta_of_defender_demos_collect():
    train, policy, costs = improving()
    env = drift(costs)
    demos = collect_demos(env, policy, 2, 2, train=train, seed=1, episode_cost_limit=5)
    assert demos.group_sizes == (2, 2)
    meta = demos.meta
    assert meta["episode_cost_limit"] == 5.0 and meta["source_training_episodes"] == [0, 1, 2, 3]
    assert "cut on the step where the episode cost passed 5; safe: reached the horizon with cost <= 5" in meta[
        "provenance"]
    # Unsafe ones stop on the sixth step (6 > 5), safe ones reach the horizon.
    assert [len(demos.episode(i)["rew"]) for i in range(4)] == [100, 6, 100, 6]
    assert env.seeds == [reset_seed(1, k) for k in range(4)]
    # The keys `defender demos collect` writes on a cost task (the shipped set is one of its).
    shipped = EpisodeSet.load(str(ROOT / "data" / "demos" / "SafetyHopperVelocity-v1.npz")).meta
    rec = DemoRecorder(drift(costs), episode_cost_limit=5)
    for k in range(2):
        train(k)
        rec.record(policy, after_episode=k)
    ours = rec.select(1, 1, training_steps=1234, learning_starts=100).meta
    assert set(ours) == set(shipped), (sorted(ours), sorted(shipped))
    assert (ours["training_steps"], ours["learning_starts"]) == (1234, 100)


def test_a_cost_labelled_set_is_what_the_wrapper_and_its_limit_take(tmp_path):
    train, policy, costs = improving()
    path = tmp_path / "drift-cost.npz"
    collect_demos(drift(costs), policy, 2, 2, train=train, episode_cost_limit=5).save(str(path))
    back = EpisodeSet.load(str(path))
    assert back.meta["episode_cost_limit"] == 5.0
    # The wrapper takes the set's limit by default, and refuses another (the Rust check).
    DefenderWrapper(drift(costs), str(path), "MinBoth/MinBoth", seed=0)
    DefenderWrapper(drift(costs), str(path), "MinBoth/MinBoth", seed=0, episode_cost_limit=5.0)
    with pytest.raises(DefenderError, match="episode_cost_limit"):
        DefenderWrapper(drift(costs), str(path), "MinBoth/MinBoth", seed=0, episode_cost_limit=25.0)


def test_the_same_seed_records_the_same_set():
    sets = []
    for _ in range(2):
        train, policy, costs = improving()
        sets.append(collect_demos(drift(costs), policy, 2, 2, train=train, seed=9, episode_cost_limit=5))
    for a, b in zip(sets[0].to_arrays().values(), sets[1].to_arrays().values()):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
