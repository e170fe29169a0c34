#!/usr/bin/env python3
"""The per-step cost of ``DefenderWrapper(check_finite=True)`` (the default: every reward,
observation and action is checked for NaN and infinity) against ``check_finite=False``
(docs/benchmarks-python.md, "Python wrapper: check_finite").

Two wrappers around Gymnasium's Hopper-v5 (the shipped demonstrations, MeanDemoW5/MeanDemoW10,
the dynamics model's training excluded as in bench_python_wrapper.py), one with the checks and
one without, take turns of ``--chunk`` steps on the same random actions, ``--rounds`` times, so
that a changing load weighs on both alike; each turn's time per step (wall and the thread's CPU
time) is one sample, and the difference of the two wrappers' paired turns is the checks' cost.

With ``--only on|off`` it times one wrapper alone and prints its mean step time (for timing the
two as whole processes side by side).

Run (after `make python`):
    .deps/venv/bin/python tools/peers/bench_check_finite.py --rounds 20 --chunk 2000
"""

from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import time

import gymnasium as gym
import numpy as np

from defender_rl import DefenderWrapper, EpisodeSet

ROOT = pathlib.Path(__file__).resolve().parents[2]


def make(check: bool, demos: EpisodeSet, seed: int) -> DefenderWrapper:
    dynamics = {"learning_starts": 1 << 60}
    env = DefenderWrapper(gym.make("Hopper-v5"), demos, "MeanDemoW5/MeanDemoW10", seed=seed, dynamics=dynamics,
                          check_finite=check)
    env.reset(seed=seed)
    return env


def turn(env: DefenderWrapper, actions: np.ndarray) -> tuple[float, float]:
    """Steps through ``actions`` (resetting at episode ends); seconds per step, wall and CPU."""
    start, start_cpu = time.perf_counter(), time.thread_time()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    n = len(actions)
    return (time.perf_counter() - start) / n, (time.thread_time() - start_cpu) / n


def spread(values: list[float]) -> str:
    us = sorted(1e6 * v for v in values)
    q1, med, q3 = statistics.quantiles(us, n=4) if len(us) > 1 else (us[0],) * 3
    return f"median {med:.2f} us (quartiles {q1:.2f}-{q3:.2f}, min {us[0]:.2f}, max {us[-1]:.2f})"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rounds", type=int, default=20)
    p.add_argument("--chunk", type=int, default=2000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--only", choices=["on", "off"], help="time one wrapper alone (whole-process comparisons)")
    args = p.parse_args()
    demos = EpisodeSet.load(ROOT / "data" / "demos" / "Hopper-v5.npz")
    rng = np.random.default_rng(args.seed)
    envs = {label: make(label == "on", demos, args.seed) for label in (["on", "off"] if not args.only else [args.only])}
    low, high = next(iter(envs.values())).action_space.low, next(iter(envs.values())).action_space.high
    wall: dict[str, list[float]] = {k: [] for k in envs}
    cpu: dict[str, list[float]] = {k: [] for k in envs}
    for r in range(args.rounds):
        actions = rng.uniform(low, high, size=(args.chunk, len(low)))
        # Alternate which goes first, so that neither always follows the other's cache state.
        for label in (list(envs) if r % 2 == 0 else list(envs)[::-1]):
            w, c = turn(envs[label], actions)
            wall[label].append(w)
            cpu[label].append(c)
    print(f"Hopper-v5, {args.rounds} rounds of {args.chunk} steps, load average {os.getloadavg()[0]:.2f}")
    for label in envs:
        print(f"  check_finite={label}: step wall {spread(wall[label])}; thread CPU {spread(cpu[label])}")
    if not args.only:
        diff_wall = [a - b for a, b in zip(wall["on"], wall["off"])]
        diff_cpu = [a - b for a, b in zip(cpu["on"], cpu["off"])]
        print(f"  paired difference on - off: wall {spread(diff_wall)}; thread CPU {spread(diff_cpu)}")


if __name__ == "__main__":
    main()
