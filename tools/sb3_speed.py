#!/usr/bin/env python3
"""Training throughput of Stable-Baselines3 SAC/TD3 on a Gymnasium MuJoCo task: the peer of
`cargo run --release -p defender-cli --example rl_speed`.

Measures environment steps per second after `learning_starts` (environment and updates
included), with SB3's defaults (batch 256, 256x256 networks, one gradient step per step; TD3
with Gaussian exploration noise 0.1), PyTorch on the CPU with a fixed number of threads.

    .deps/tools-venv/bin/python tools/sb3_speed.py sac Hopper-v5 [measured_steps] [learning_starts] [threads]
"""

import sys
import time

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import SAC, TD3
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.noise import NormalActionNoise


class Clock(BaseCallback):
    """Timestamps the step at which learning starts and the last step."""

    def __init__(self, learning_starts: int, last: int):
        super().__init__()
        self.learning_starts, self.last = learning_starts, last
        self.started = self.ended = None

    def _on_step(self) -> bool:
        if self.num_timesteps == self.learning_starts:
            self.started = time.perf_counter()
        if self.num_timesteps == self.last:
            self.ended = time.perf_counter()
        return True


def main() -> None:
    algo = sys.argv[1] if len(sys.argv) > 1 else "sac"
    env_id = sys.argv[2] if len(sys.argv) > 2 else "Hopper-v5"
    measured = int(sys.argv[3]) if len(sys.argv) > 3 else 2000
    learning_starts = int(sys.argv[4]) if len(sys.argv) > 4 else 1000
    threads = int(sys.argv[5]) if len(sys.argv) > 5 else 2
    torch.set_num_threads(threads)
    env = gym.make(env_id)
    if algo == "sac":
        model = SAC("MlpPolicy", env, learning_starts=learning_starts, device="cpu", seed=0)
    elif algo == "td3":
        n = env.action_space.shape[0]
        noise = NormalActionNoise(np.zeros(n), 0.1 * np.ones(n))
        model = TD3("MlpPolicy", env, learning_starts=learning_starts, action_noise=noise, device="cpu", seed=0)
    else:
        raise SystemExit(f"unknown algo {algo!r}: sac or td3")
    total = learning_starts + measured
    clock = Clock(learning_starts, total)
    model.learn(total_timesteps=total, callback=clock)
    span = clock.ended - clock.started
    print(
        f"sb3 {algo} {env_id}: {measured} steps after learning_starts={learning_starts} in {span:.2f} s: "
        f"{measured / span:.1f} steps/s; torch threads {threads}, torch {torch.__version__}"
    )


if __name__ == "__main__":
    main()
