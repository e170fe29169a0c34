"""Recording demonstrations as `defender demos collect` does (DemoRecorder, collect_demos)."""

from __future__ import annotations

import numpy as np
import pytest

from defender_rl import DefenderError, DemoRecorder, collect_demos, derive_seed
from defender_rl.demos import reset_seed, spread


def test_spread_matches_the_rust_rule():
    assert spread(list(range(10)), 1) == [9]
    assert spread(list(range(10)), 2) == [0, 9]
    assert spread(list(range(10)), 10) == list(range(10))
    picked = spread(list(range(100)), 5)
    assert picked[0] == 0 and picked[-1] == 99 and len(set(picked)) == 5


def test_collect_demos_with_an_improving_policy():
    # A "training" policy that gets better: early episodes crash, later ones hold on.
    skill = {"k": 0}

    def train(k):
        skill["k"] = k

    def policy(obs):
        gain = min(skill["k"] / 10, 1.0)
        return np.array([np.clip(gain * (-3 * obs[0] - 2 * obs[1]) + (1 - gain), -1, 1)], dtype=np.float32)

    demos = collect_demos("DefenderTest/Drift-v0", policy, 3, 3, train=train, seed=4)
    assert demos.group_sizes == (3, 3)
    assert demos.env_id == "DefenderTest/Drift-v0"
    meta = demos.meta
    assert "evenly spaced" in meta["selection"] and len(meta["source_training_episodes"]) == 6


def test_recorder_seeds_as_the_rust_tools_and_refuses_too_few():
    rec = DemoRecorder("DefenderTest/Drift-v0", seed=2)
    crashed = rec.record(lambda o: np.array([1.0], dtype=np.float32), after_episode=7)
    assert crashed and rec.group_sizes == (0, 1)
    obs0 = rec.candidates[0][0][0]
    # The command line's derived seed, folded to 32 bits (every Gymnasium environment takes it).
    assert reset_seed(2, 7) == (lambda s: (s ^ (s >> 32)) & 0xFFFFFFFF)(derive_seed(2, "demonstration", 7))
    expected, _ = rec.env.reset(seed=reset_seed(2, 7))
    np.testing.assert_array_equal(obs0, expected)
    with pytest.raises(DefenderError, match="0 safe and 1 unsafe candidates"):
        rec.select(1, 1)
