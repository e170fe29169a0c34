#!/usr/bin/env python3
"""Training throughput of a Python peer, Stable-Baselines3 (PyTorch) or SBX (the same SAC/TD3
on JAX, `pip install sbx-rl`), on a Gymnasium MuJoCo task: the peer of `defender train` in
`tools/peers/bench_peers.py` (and of `cargo run --release -p defender-cli --example rl_speed`).

Protocol: `learning_starts` uniformly random steps, then `warmup` steps with one gradient step
each (untimed: JIT compilation, allocator and cache warm-up), then `measured` timed steps
(environment and one gradient step each). Defaults of both libraries (batch 256, 256x256
networks, Adam 3e-4, one gradient step per step; TD3 with Gaussian exploration noise 0.1), on
the CPU; PyTorch with a fixed number of threads (JAX: restrict the process's CPUs, e.g. taskset).

    python tools/peers/sb3_speed.py sac Hopper-v5 [measured] [learning_starts] [threads] [--lib sb3|sbx] [--warmup N]

Prints one human line and, with --json, one JSON line (the figures bench_peers.py reads).
"""

import argparse
import json
import time

import gymnasium as gym
import numpy as np


class Clock:
    """Timestamps the start and the end of the timed steps (a callback of either library)."""

    def __init__(self, start: int, last: int):
        self.start, self.last = start, last
        self.started = self.ended = None

    def callback(self):
        from stable_baselines3.common.callbacks import BaseCallback

        clock = self

        class _Callback(BaseCallback):
            def _on_step(self) -> bool:
                if self.num_timesteps == clock.start:
                    clock.started = time.perf_counter()
                if self.num_timesteps == clock.last:
                    clock.ended = time.perf_counter()
                return True

        return _Callback()


def build(lib: str, algo: str, env, learning_starts: int):
    if lib == "sb3":
        import torch
        from stable_baselines3 import SAC, TD3

        version = f"stable-baselines3 {__import__('stable_baselines3').__version__}, torch {torch.__version__}"
    elif lib == "sbx":
        import jax
        from sbx import SAC, TD3

        version = f"sbx {__import__('sbx').__version__}, jax {jax.__version__}"
    else:
        raise SystemExit(f"unknown library {lib!r}: sb3 or sbx")
    kwargs = {"learning_starts": learning_starts, "seed": 0, "verbose": 0}
    if lib == "sb3":
        kwargs["device"] = "cpu"
    if algo == "sac":
        return SAC("MlpPolicy", env, **kwargs), version
    if algo == "td3":
        from stable_baselines3.common.noise import NormalActionNoise

        n = env.action_space.shape[0]
        noise = NormalActionNoise(np.zeros(n), 0.1 * np.ones(n))
        return TD3("MlpPolicy", env, action_noise=noise, **kwargs), version
    raise SystemExit(f"unknown algo {algo!r}: sac or td3")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("algo", nargs="?", default="sac")
    p.add_argument("env_id", nargs="?", default="Hopper-v5")
    p.add_argument("measured", nargs="?", type=int, default=2000)
    p.add_argument("learning_starts", nargs="?", type=int, default=1000)
    p.add_argument("threads", nargs="?", type=int, default=2)
    p.add_argument("--lib", default="sb3", choices=["sb3", "sbx"])
    p.add_argument("--warmup", type=int, default=0, help="untimed steps with updates before the timed ones")
    p.add_argument("--json", action="store_true", help="also print the figures as one JSON line")
    args = p.parse_args()
    if args.lib == "sb3":
        import torch

        torch.set_num_threads(args.threads)
    env = gym.make(args.env_id)
    model, version = build(args.lib, args.algo, env, args.learning_starts)
    start = args.learning_starts + args.warmup
    total = start + args.measured
    clock = Clock(start, total)
    model.learn(total_timesteps=total, callback=clock.callback())
    span = clock.ended - clock.started
    rate = args.measured / span
    print(
        f"{args.lib} {args.algo} {args.env_id}: {args.measured} steps after {args.learning_starts} random "
        f"and {args.warmup} warm-up steps in {span:.2f} s: {rate:.1f} steps/s; threads {args.threads}, {version}"
    )
    if args.json:
        print(json.dumps({"lib": args.lib, "algo": args.algo, "steps_per_second": rate, "seconds": span, "version": version}))


if __name__ == "__main__":
    main()
