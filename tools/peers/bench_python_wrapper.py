#!/usr/bin/env python3
"""Benchmark of the Python front (docs/benchmarks-python.md, "Python wrapper").

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
   its own thread (``dynamics={"background": True}``), side by side in this process: the three
   take turns of ``--sb3-chunk`` steps until each has taken STEPS, so that a changing load weighs
   on all of them alike; % Time = wall time / the bare run's. The dynamics model trains on SPEC
   section 5's schedule (one gradient step per real step).

Run (after `make python`):
    .deps/venv/bin/python tools/peers/bench_python_wrapper.py                 # 1 only
    .deps/venv/bin/python tools/peers/bench_python_wrapper.py --sb3 5000      # 1 and 2
    .deps/venv/bin/python tools/peers/bench_python_wrapper.py --skip-wrapper --sb3 5000   # 2 only
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

ROOT = pathlib.Path(__file__).resolve().parents[2]


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


def sb3_runs(env_id: str, demos: EpisodeSet, strategy: str, steps: int, seed: int, chunk: int) -> list[tuple[str, float, dict]]:
    """SB3 SAC bare, with DEFENDER (model inline) and with DEFENDER's model on its own thread,
    side by side: the three agents take turns, `chunk` steps each (``learn(...,
    reset_num_timesteps=False)``), so a load that changes during the run weighs on all three
    alike; each one's wall time is the sum of its turns. All three use SB3's defaults
    (``learning_starts=100``: every later step is an env step plus one gradient step)."""
    import torch
    from stable_baselines3 import SAC

    runs = []
    for label, dynamics in [("bare", None), ("DEFENDER", {}), ("DEFENDER, model on its own thread", {"background": True})]:
        env = gym.make(env_id)
        if dynamics is not None:
            env = DefenderWrapper(env, demos, strategy, seed=seed, dynamics=dynamics)
        runs.append([label, env, SAC("MlpPolicy", env, seed=seed, verbose=0, device="cpu"), 0.0, 0])
    while any(r[4] < steps for r in runs):
        for run in runs:
            n = min(chunk, steps - run[4])
            if n <= 0:
                continue
            start = time.perf_counter()
            run[2].learn(total_timesteps=n, reset_num_timesteps=run[4] == 0)
            run[3] += time.perf_counter() - start
            run[4] += n
        done = min(r[4] for r in runs)
        print(f"  {done}/{steps} steps each: " + ", ".join(f"{r[0]} {r[3]:.1f} s" for r in runs)
              + f" (load average {os.getloadavg()[0]:.2f})", flush=True)
    out = []
    for label, env, _, seconds, n in runs:
        stats = env.defender_stats if isinstance(env, DefenderWrapper) else {}
        if stats:
            stats = {**stats, **{k: env.dynamics_info[k] for k in ("gradient_steps", "prediction_error_ema")}}
        out.append((label, seconds, stats))
        print(f"  SB3 SAC {label}: {n} steps in {seconds:.1f} s ({n / seconds:.1f} steps/s) {stats}", flush=True)
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
    p.add_argument("--sb3-chunk", type=int, default=500, metavar="STEPS", help="steps per turn of the SB3 runs")
    p.add_argument("--torch-threads", type=int, default=0, help="torch.set_num_threads (0: torch's default)")
    p.add_argument("--skip-wrapper", action="store_true", help="only the SB3 comparison")
    args = p.parse_args()
    demos = EpisodeSet.load(ROOT / "data" / "demos" / f"{args.env}.npz")
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.processor() or platform.platform()}, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{args.env}, {args.strategy}, {len(demos)} demonstrations, {args.steps} steps of random actions, "
          f"dynamics training excluded")
    for background, what in [] if args.skip_wrapper else [(False, "model inline"), (True, "model on its own thread")]:
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
        if args.torch_threads:
            import torch

            torch.set_num_threads(args.torch_threads)
        results = sb3_runs(args.env, demos, args.strategy, args.sb3, args.seed, args.sb3_chunk)
        bare = results[0][1]
        for label, seconds, _ in results:
            print(f"  % Time {label}: {100 * seconds / bare:.1f}%")


if __name__ == "__main__":
    main()
