#!/usr/bin/env python3
"""Gymnasium 1.4.0's environment steps per second, the peer of `cargo bench -p defender-mujoco`.

Same loop as crates/defender-mujoco/benches/steps.rs: 64 precomputed sinusoidal actions cycled,
reset when an episode ends, through `gymnasium.make(id)` (with its default wrappers). One core.

  .deps/tools-venv/bin/python tools/peers/gym_bench.py [--steps 20000]
"""

import argparse
import time

import gymnasium as gym
import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=20000)
    args = parser.parse_args()
    for env_id in ("Hopper-v5", "Walker2d-v5", "InvertedDoublePendulum-v5"):
        env = gym.make(env_id)
        env.reset(seed=0)
        nu = env.action_space.shape[0]
        actions = np.sin(0.3 * np.arange(64)[:, None] + np.arange(nu)[None, :])
        for t in range(1000):  # warm-up
            _, _, term, trunc, _ = env.step(actions[t % 64])
            if term or trunc:
                env.reset()
        start = time.perf_counter()
        for t in range(args.steps):
            _, _, term, trunc, _ = env.step(actions[t % 64])
            if term or trunc:
                env.reset()
        elapsed = time.perf_counter() - start
        print(f"{env_id:28s} {args.steps / elapsed:10.0f} steps/s  ({1e6 * elapsed / args.steps:.1f} us/step)")
        env.close()


if __name__ == "__main__":
    main()
