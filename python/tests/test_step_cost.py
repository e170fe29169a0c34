"""DefenderWrapper's safety cost (docs/SPEC.md, section 12): read from the wrapped environment's
step ``info`` (``cost_key``), 0 on a filtered step, the crash rule when the default key is
absent, and errors that name the key when an explicit key is missing or a cost is bad."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from defender_rl import DefenderError, DefenderWrapper

from conftest import DriftEnv

# Under SPEC's filter (profile="spec") on the drift task, full throttle looks like the unsafe
# demonstrations and is filtered within a few steps; full reverse is not, and crashes (|x| > 1).
FORWARD, REVERSE = np.array([1.0], np.float32), np.array([-1.0], np.float32)


class CostInInfo(gym.Wrapper):
    """Puts a known cost into every step's ``info`` under ``key``: ``costs(step)`` of the
    episode's step number (1-based)."""

    def __init__(self, env: gym.Env, key: str = "cost", costs=lambda t: 0.25 * t):
        super().__init__(env)
        self.key, self.costs, self.t = key, costs, 0

    def reset(self, **kwargs):
        self.t = 0
        return self.env.reset(**kwargs)

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.t += 1
        info[self.key] = self.costs(self.t)
        return obs, reward, terminated, truncated, info


def episode(env, action, seed):
    """The ``info`` of every step of one episode with a constant action."""
    env.reset(seed=seed)
    infos = []
    while True:
        _, _, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            return infos


def test_the_info_cost_passes_through_and_a_filtered_step_costs_nothing(drift_set):
    env = DefenderWrapper(CostInInfo(DriftEnv()), drift_set, "MinBoth/MinBoth", seed=0, profile="spec")
    crashed = episode(env, REVERSE, seed=1)
    assert crashed[-1]["defender_outcome"] == "crashed"
    # The environment's own cost, not the crash rule (which would give 0, 0, ..., 1).
    assert [i["cost"] for i in crashed] == [0.25 * t for t in range(1, len(crashed) + 1)]
    filtered = episode(env, FORWARD, seed=2)
    assert filtered[-1]["defender_outcome"] == "filtered" and filtered[-1]["defender_filtered"]
    assert filtered[-1]["cost"] == 0.0, "the filtered action never reached the environment"
    assert [i["cost"] for i in filtered[:-1]] == [0.25 * t for t in range(1, len(filtered))]
    assert len(filtered) > 1 and filtered[-2]["cost"] > 0


def test_a_named_key_is_read_and_returned_as_cost(drift_set):
    inner = CostInInfo(DriftEnv(), key="cost_hazards", costs=lambda t: 2.0)
    env = DefenderWrapper(inner, drift_set, "MinBoth/MinBoth", seed=0, profile="spec", cost_key="cost_hazards")
    infos = episode(env, REVERSE, seed=1)
    assert all(i["cost"] == 2.0 and i["cost_hazards"] == 2.0 for i in infos)


def test_the_spec_rebuilds_the_wrapper_with_its_cost_key(drift_set):
    # An explicit key is recorded (the rebuilt wrapper is as strict); the default is not, so that
    # the rebuilt wrapper keeps the crash rule for an info without "cost".
    for kwargs in ({}, {"cost_key": None}, {"cost_key": "cost"}):
        env = DefenderWrapper(gym.make("DefenderTest/Drift-v0"), drift_set, seed=0, **kwargs)
        recorded = env.spec.additional_wrappers[-1].kwargs
        assert {k: v for k, v in recorded.items() if k == "cost_key"} == kwargs
        rebuilt = gym.make(env.spec)
        rebuilt.reset(seed=0)
        if kwargs.get("cost_key") == "cost":
            with pytest.raises(DefenderError, match="cost_key"):
                rebuilt.step(REVERSE)
        else:
            assert rebuilt.step(REVERSE)[4]["cost"] == 0.0


def test_without_the_default_key_a_step_costs_by_the_crash_rule(drift_set):
    for cost_key in ("default", None):
        kwargs = {} if cost_key == "default" else {"cost_key": cost_key}
        # cost_key=None ignores a cost the environment does put into its info.
        inner = DriftEnv() if cost_key == "default" else CostInInfo(DriftEnv(), costs=lambda t: 7.0)
        env = DefenderWrapper(inner, drift_set, "MinBoth/MinBoth", seed=0, profile="spec", **kwargs)
        crashed = episode(env, REVERSE, seed=1)
        assert crashed[-1]["defender_outcome"] == "crashed"
        assert [i["cost"] for i in crashed] == [0.0] * (len(crashed) - 1) + [1.0], cost_key
        filtered = episode(env, FORWARD, seed=2)
        assert filtered[-1]["defender_outcome"] == "filtered"
        assert all(i["cost"] == 0.0 for i in filtered), cost_key


def test_an_explicit_key_missing_from_info_raises_naming_it(drift_set):
    for key in ("cost", "cost_hazards"):
        env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=0, profile="spec", cost_key=key)
        env.reset(seed=0)
        with pytest.raises(DefenderError) as e:
            env.step(REVERSE)
        msg = str(e.value)
        assert f'cost_key="{key}"' in msg and "'inner_key'" in msg and "step 1 of the episode" in msg, msg


@pytest.mark.parametrize(
    ("value", "error", "words"),
    [
        (-0.5, DefenderError, "is -0.5"),
        (math.nan, DefenderError, "is NaN"),
        (math.inf, DefenderError, "is inf"),
        ("high", TypeError, "not a number: 'high'"),
    ],
)
def test_a_bad_cost_raises_naming_the_key(drift_set, value, error, words):
    inner = CostInInfo(DriftEnv(), key="c", costs=lambda t: value)
    env = DefenderWrapper(inner, drift_set, "MinBoth/MinBoth", seed=0, cost_key="c")
    env.reset(seed=0)
    with pytest.raises(error) as e:
        env.step(REVERSE)
    msg = str(e.value)
    assert 'info["c"] (cost_key)' in msg and words in msg, msg


def test_numpy_and_bool_costs_are_numbers(drift_set):
    for value, expected in ((np.float32(0.5), 0.5), (np.float64(3.0), 3.0), (True, 1.0), (np.array(2.0), 2.0)):
        env = DefenderWrapper(CostInInfo(DriftEnv(), costs=lambda t: value), drift_set, seed=0)
        env.reset(seed=0)
        assert env.step(REVERSE)[4]["cost"] == expected


def test_cost_key_must_be_a_string_or_none(drift_set):
    with pytest.raises(TypeError, match="cost_key must be a string"):
        DefenderWrapper(DriftEnv(), drift_set, cost_key=3)


def cost_labelled(limit: float) -> "defender_rl.EpisodeSet":
    """The drift demonstrations, labelled (in their meta) as cut by an episode cost limit."""
    import defender_rl
    from conftest import drift_demos

    d = drift_demos()
    episodes = [(d.episode(i)["obs"], d.episode(i)["act"], d.episode(i)["rew"], bool(d.episode(i)["crashed"]))
                for i in range(len(d))]
    return defender_rl.EpisodeSet.from_episodes(
        episodes, env_id="DefenderTest/Drift-v0", meta={"episode_cost_limit": limit})


def test_own_episodes_join_by_the_demonstrations_episode_cost_limit():
    # Every step costs 1: an episode passes the limit of 2 on its third step, long before it
    # crashes (|x| > 1 under full reverse), so it joins the unsafe group by its cost.
    env = DefenderWrapper(CostInInfo(DriftEnv(), costs=lambda t: 1.0), cost_labelled(2.0),
                          "MinBoth/MinBoth", seed=0, profile="spec", filter={"own_episodes": {"keep": 5}})
    infos = episode(env, REVERSE, seed=1)
    assert len(infos) > 3 and infos[-1]["defender_outcome"] == "crashed"
    assert (env.filter_state["own_safe"], env.filter_state["own_unsafe"]) == (0, 1)
    # A cost that stays within the limit: the crash alone does not make it unsafe on a cost task.
    env = DefenderWrapper(CostInInfo(DriftEnv(), costs=lambda t: 0.0), cost_labelled(2.0),
                          "MinBoth/MinBoth", seed=0, profile="spec", filter={"own_episodes": {"keep": 5}})
    episode(env, REVERSE, seed=1)
    assert (env.filter_state["own_safe"], env.filter_state["own_unsafe"]) == (0, 0)


def test_a_limit_the_demonstrations_were_not_labelled_by_raises_naming_it(drift_set):
    with pytest.raises(DefenderError, match="episode_cost_limit"):
        DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", episode_cost_limit=25.0)
    with pytest.raises(DefenderError, match="episode_cost_limit"):
        DefenderWrapper(DriftEnv(), cost_labelled(2.0), "MinBoth/MinBoth", episode_cost_limit=3.0)
    with pytest.raises(TypeError, match="episode_cost_limit"):
        DefenderWrapper(DriftEnv(), cost_labelled(2.0), "MinBoth/MinBoth", episode_cost_limit="25")
