"""DefenderWrapper(filter=...): the filter's precision options ([defender.filter]) from Python:
they reach the Rust core, move between episodes, and bad values are named."""

from __future__ import annotations

import numpy as np
import pytest

from defender_rl import DefenderError, DefenderWrapper

from conftest import DriftEnv


def full_throttle_episodes(env, episodes):
    outcomes = []
    for ep in range(episodes):
        env.reset(seed=ep)
        while True:
            _, _, terminated, truncated, _ = env.step(np.array([1.0], dtype=np.float32))
            if terminated or truncated:
                outcomes.append(env.last_outcome)
                break
    return outcomes


def test_a_budget_raises_the_margin_after_filtered_episodes(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, profile="spec",
                          filter={"budget": {"share": 0.1, "episodes": 10}})
    assert env.filter_state == {"margin": 0.0, "own_safe": 0, "own_unsafe": 0}
    outcomes = full_throttle_episodes(env, 3)
    filtered = outcomes.count("filtered")
    assert filtered > 0, outcomes
    # Each filtered episode adds (1 - 0.1) / 10, each other one takes 0.1 / 10 (floored at 0).
    assert env.filter_state["margin"] > 0.0
    plain = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, profile="spec")
    full_throttle_episodes(plain, 3)
    assert plain.filter_state["margin"] == 0.0


def test_own_crashes_join_the_unsafe_group(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1,
                          filter={"margin": 0.99, "own_episodes": {"keep": 2}})
    outcomes = full_throttle_episodes(env, 4)
    crashed = outcomes.count("crashed")
    assert crashed > 0, outcomes
    assert env.filter_state["own_unsafe"] == min(crashed, 2)


@pytest.mark.parametrize(
    "bad, exc, words",
    [
        ({"margin": 1.0}, DefenderError, "margin = 1"),
        ({"margin": True}, TypeError, "filter['margin']"),
        ({"margin": float("nan")}, DefenderError, "filter['margin']"),
        ({"budget": {"share": 0.0}}, DefenderError, "share = 0"),
        ({"budget": 0.2}, TypeError, "filter['budget']"),
        ({"own_episodes": {"keep": 0}}, DefenderError, "keep = 0"),
        ({"own_episodes": {"keep": -1}}, DefenderError, "filter['own_episodes']['keep']"),
        ({"margins": 0.2}, DefenderError, "margins"),
        ("margin=0.2", TypeError, "filter must be a dict"),
    ],
)
def test_bad_filter_values_are_named(drift_set, bad, exc, words):
    with pytest.raises(exc, match=None) as e:
        DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, filter=bad)
    assert words in str(e.value), str(e.value)


def test_the_keeps_learning_profile_gives_its_filter_and_filter_wins(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1)
    assert env.profile == "keeps-learning", "the default profile"
    assert env.filter_state == {"margin": 0.02, "own_safe": 0, "own_unsafe": 0}
    outcomes = full_throttle_episodes(env, 4)
    assert env.filter_state["own_unsafe"] == min(outcomes.count("crashed"), 50)
    over = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, profile="keeps-learning",
                           filter={"margin": 0.5})
    assert over.filter_state["margin"] == 0.5
    spec = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, profile="spec")
    assert spec.profile == "spec" and spec.filter_state["margin"] == 0.0


@pytest.mark.parametrize(
    "bad, exc, words",
    [("authors", DefenderError, "defender train --profile authors"), ("paper", DefenderError, "'paper'"),
     (3, TypeError, "profile must be")],
)
def test_bad_profiles_are_named(drift_set, bad, exc, words):
    with pytest.raises(exc) as e:
        DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=1, profile=bad)
    assert words in str(e.value), str(e.value)
