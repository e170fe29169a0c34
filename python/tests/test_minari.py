"""EpisodeSet.from_minari on a dataset made here with Minari's own DataCollector (nothing is
downloaded: MINARI_DATASETS_PATH points at a temporary folder)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderWrapper, EpisodeSet

minari = pytest.importorskip("minari")  # in python/requirements-test.txt: never skipped by make test


@pytest.fixture
def drift_dataset(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    env = minari.DataCollector(gym.make("DefenderTest/Drift-v0"))
    rng = np.random.default_rng(0)
    for ep in range(12):
        obs, _ = env.reset(seed=ep)
        throttle = ep % 2 == 1  # odd episodes drive off the line (crash), even ones hold x near 0
        while True:
            a = 1.0 if throttle else float(np.clip(-3 * obs[0] - 2 * obs[1] + 0.1 * rng.normal(), -1, 1))
            obs, _, term, trunc, _ = env.step(np.array([a], dtype=np.float32))
            if term or trunc:
                break
    dataset = env.create_dataset(dataset_id="defendertest/drift-mixed-v0", algorithm_name="scripted")
    env.close()
    return dataset


def test_from_minari_uses_terminations_as_crashes(drift_dataset):
    s = EpisodeSet.from_minari(drift_dataset)
    assert len(s) == 12 and s.group_sizes == (6, 6)
    assert s.env_id == "DefenderTest/Drift-v0" and s.obs_dim == 2 and s.act_dim == 1
    for i, ep in enumerate(drift_dataset.iterate_episodes()):
        e = s.episode(i)
        np.testing.assert_allclose(e["obs"], ep.observations, rtol=1e-6)
        np.testing.assert_allclose(e["act"], ep.actions, rtol=1e-6)
        np.testing.assert_allclose(e["rew"], ep.rewards, rtol=1e-6)
        assert e["crashed"] == bool(ep.terminations[-1])
    # Loaded by id (locally), and with a user's rule.
    by_id = defender_rl.from_minari("defendertest/drift-mixed-v0", crashed=lambda ep: len(ep.rewards) < 50)
    assert len(by_id) == 12
    # It is a demonstration set the wrapper accepts.
    env = DefenderWrapper(gym.make("DefenderTest/Drift-v0"), s, "MinBoth/MinBoth", seed=0)
    env.reset(seed=0)
    assert "defender_filtered" in env.step(np.zeros(1, dtype=np.float32))[4]
