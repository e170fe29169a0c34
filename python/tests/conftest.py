"""Shared fixtures of the defender-rl tests: the repository's paths, the release `defender` binary,
a small pure-Python environment with a 1-D Box observation and action space, and demonstrations
for it."""

from __future__ import annotations

import pathlib
import subprocess

import gymnasium as gym
import numpy as np
import pytest

import defender_rl

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOPPER_DEMOS = ROOT / "data" / "demos" / "Hopper-v5.npz"


@pytest.fixture(scope="session")
def binary() -> pathlib.Path:
    """The release `defender` command, built once if absent (the tools and CLI tests run it)."""
    exe = ROOT / "target" / "release" / "defender"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "-p", "defender-cli"], cwd=ROOT, check=True)
    return exe


class DriftEnv(gym.Env):
    """A point on a line: obs (x, v), action a in [-1, 1]; v += 0.1 a + drift, x += 0.1 v.
    Terminated (a crash) when |x| > 1; the reward is 1 - |x|. Counts the steps it really took."""

    metadata = {"render_modes": []}

    def __init__(self, drift: float = 0.02):
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(2,), dtype=np.float64)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.drift = drift
        self.state = np.zeros(2)
        self.real_steps = 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.state = self.np_random.uniform(-0.05, 0.05, size=2)
        self.episode_steps = 0
        return self.state.copy(), {"reset_info": 1}

    def step(self, action):
        a = float(np.asarray(action).reshape(-1)[0])
        x, v = self.state
        v = v + 0.1 * a + self.drift
        x = x + 0.1 * v
        self.state = np.array([x, v])
        self.real_steps += 1
        self.episode_steps += 1
        return self.state.copy(), 1.0 - abs(x), bool(abs(x) > 1.0), False, {"inner_key": self.episode_steps}


# A string entry point, so that the spec serialises (Minari writes it into its datasets).
gym.register("DefenderTest/Drift-v0", entry_point="conftest:DriftEnv", max_episode_steps=100)


def drift_demos(n: int = 4, seed: int = 0) -> defender_rl.EpisodeSet:
    """n safe episodes (a controller holds x near 0 for 30 steps) and n unsafe ones (full
    throttle until |x| > 1), recorded on DriftEnv."""
    rng = np.random.default_rng(seed)
    episodes = []
    for crashed in (False, True):
        for _ in range(n):
            env = DriftEnv()
            obs, _ = env.reset(seed=int(rng.integers(1 << 30)))
            obs_l, act_l, rew_l = [obs], [], []
            for _ in range(30 if not crashed else 200):
                x, v = obs
                a = np.clip(-3 * x - 2 * v, -1, 1) if not crashed else 1.0
                obs, r, term, _, _ = env.step(np.array([a], dtype=np.float32))
                obs_l.append(obs)
                act_l.append([a])
                rew_l.append(r)
                if term:
                    break
            episodes.append((np.array(obs_l), np.array(act_l), np.array(rew_l), crashed))
    return defender_rl.EpisodeSet.from_episodes(episodes, env_id="DefenderTest/Drift-v0")


@pytest.fixture
def drift_set() -> defender_rl.EpisodeSet:
    return drift_demos()
