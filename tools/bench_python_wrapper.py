#!/usr/bin/env python3
"""Benchmark of the Python front (docs/benchmarks.md, "Python wrapper").

1. The wrapper's own cost per step on Gymnasium's Hopper-v5 with MeanDemoW5/MeanDemoW10 and the
   shipped demonstrations, the dynamics model's training excluded (``learning_starts`` beyond
   the run: the model still takes every real transition into its buffer and predicts every
   filtered step). The inner environment is timed by a thin wrapper under DefenderWrapper, so
   "own cost" = time in ``DefenderWrapper.step`` minus time in the inner ``env.step`` (and the
   same for ``reset``). Measured twice: with the model inline (each real transition also costs
   the model's held-out prediction, one forward pass, on the caller's thread) and with
   ``background=True`` (the transition is handed to the model's thread). Actions are uniform random, so episodes end early (filtered or crashed)
   and resets are frequent: both are in the figures.
2. With ``--sb3 STEPS`` (needs stable-baselines3 + torch: python/requirements-sb3.txt): SB3 SAC on
   Hopper-v5 bare, with DEFENDER (model trained inline) and with DEFENDER training its model on
   its own thread (``dynamics={"background": True}``), one after the other in this process, each
   for STEPS steps; % Time = wall time / the bare run's.

Run (after `make python`):
    .deps/venv/bin/python tools/bench_python_wrapper.py                 # 1 only
    .deps/venv/bin/python tools/bench_python_wrapper.py --sb3 5000      # 1 and 2
"""

from __future__ import annotations

import argparse
import os
import pathlib
import platform
import time

import gymnasium as gym
import numpy as np

from defender_rl import DefenderWrapper, EpisodeSet

ROOT = pathlib.Path(__file__).resolve().parents[1]


class Timed(gym.Wrapper):
    """Accumulates the time spent in the wrapped environment's step and reset."""

    def __init__(self, env):
        super().__init__(env)
        self.seconds = 0.0
        self.cpu = 0.0

    def step(self, action):
        t, c = time.perf_counter(), time.thread_time()
        out = self.env.step(action)
        self.seconds += time.perf_counter() - t
        self.cpu += time.thread_time() - c
        return out

    def reset(self, **kwargs):
        t, c = time.perf_counter(), time.thread_time()
        out = self.env.reset(**kwargs)
        self.seconds += time.perf_counter() - t
        self.cpu += time.thread_time() - c
        return out


def wrapper_cost(env_id: str, demos: EpisodeSet, strategy: str, steps: int, seed: int, background: bool) -> dict:
    inner = Timed(gym.make(env_id))
    dynamics = {"learning_starts": 1 << 60, "background": background}
    env = DefenderWrapper(inner, demos, strategy, seed=seed, dynamics=dynamics)
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low, env.action_space.high
    actions = rng.uniform(low, high, size=(steps, len(low)))
    env.reset(seed=seed)
    inner.seconds = inner.cpu = 0.0
    filtered = 0
    start, start_cpu = time.perf_counter(), time.thread_time()
    for t in range(steps):
        _, _, terminated, truncated, info = env.step(actions[t])
        filtered += info["defender_filtered"]
        if terminated or truncated:
            env.reset()
    total = time.perf_counter() - start
    total_cpu = time.thread_time() - start_cpu
    stats = env.defender_stats
    return {
        "steps": steps,
        "episodes": stats["episodes"],
        "filtered_steps": filtered,
        "total_us": 1e6 * total / steps,
        "inner_us": 1e6 * inner.seconds / steps,
        "own_us": 1e6 * (total - inner.seconds) / steps,
        # CPU time of the calling thread: what the wrapper costs the agent's thread, unaffected
        # by time spent descheduled on a loaded machine.
        "own_cpu_us": 1e6 * (total_cpu - inner.cpu) / steps,
        "inner_cpu_us": 1e6 * inner.cpu / steps,
    }


def sb3_runs(env_id: str, demos: EpisodeSet, strategy: str, steps: int, seed: int) -> list[tuple[str, float, dict]]:
    import torch
    from stable_baselines3 import SAC

    out = []
    for label, dynamics in [("bare", None), ("DEFENDER", {}), ("DEFENDER, model on its own thread", {"background": True})]:
        env = gym.make(env_id)
        if dynamics is not None:
            env = DefenderWrapper(env, demos, strategy, seed=seed, dynamics=dynamics)
        model = SAC("MlpPolicy", env, seed=seed, verbose=0, device="cpu")
        start = time.perf_counter()
        model.learn(total_timesteps=steps)
        seconds = time.perf_counter() - start
        stats = env.defender_stats if dynamics is not None else {}
        out.append((label, seconds, stats))
        print(f"  SB3 SAC {label}: {steps} steps in {seconds:.1f} s ({steps / seconds:.0f} steps/s) {stats}", flush=True)
    print(f"  torch {torch.__version__}, {torch.get_num_threads()} threads")
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="Hopper-v5")
    p.add_argument("--strategy", default="MeanDemoW5/MeanDemoW10")
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--sb3", type=int, default=0, metavar="STEPS", help="also time SB3 SAC bare vs with DEFENDER")
    args = p.parse_args()
    demos = EpisodeSet.load(ROOT / "data" / "demos" / f"{args.env}.npz")
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.processor() or platform.platform()}, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{args.env}, {args.strategy}, {len(demos)} demonstrations, {args.steps} steps of random actions, "
          f"dynamics training excluded")
    for background, what in [(False, "model inline"), (True, "model on its own thread")]:
        runs = []
        for r in range(args.repeats):
            res = wrapper_cost(args.env, demos, args.strategy, args.steps, args.seed + r, background)
            runs.append(res)
            print(f"  {what}, run {r}: {res['episodes']} episodes, {res['filtered_steps']} filtered steps; per step: "
                  f"total {res['total_us']:.1f} us, inner env {res['inner_us']:.1f} us, "
                  f"DefenderWrapper's own {res['own_us']:.1f} us; thread CPU time: inner env "
                  f"{res['inner_cpu_us']:.1f} us, DefenderWrapper's own {res['own_cpu_us']:.1f} us", flush=True)
        best = min(runs, key=lambda r: r["own_us"])
        print(f"DefenderWrapper's own cost per step, {what}: wall {best['own_us']:.1f} us (best of {args.repeats}; "
              f"median {np.median([r['own_us'] for r in runs]):.1f} us); calling thread's CPU time "
              f"{min(r['own_cpu_us'] for r in runs):.1f} us (best; median "
              f"{np.median([r['own_cpu_us'] for r in runs]):.1f} us)")
    if args.sb3:
        results = sb3_runs(args.env, demos, args.strategy, args.sb3, args.seed)
        bare = results[0][1]
        for label, seconds, _ in results:
            print(f"  % Time {label}: {100 * seconds / bare:.1f}%")


if __name__ == "__main__":
    main()
