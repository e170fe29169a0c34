"""The offline ablation on one thread, on every core of this machine, and spread over a local Ray
cluster (`defender_rl.ray_ablation`), side by side on the same episodes; the scores must agree.

    .deps/venv/bin/python scripts/bench_ray_ablation.py [--task InvertedDoublePendulum-v5]
        [--min-len 50] [--max-len 300] [--cpus 2]

The episodes are those of the ablation sweep's bare run (`bash scripts/ablation.sh`) whose length
lies in [min-len, max-len]: all 576 strategies, so the Equal window's O(n^3) dominates.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import defender_rl
from defender_rl import EpisodeSet
from defender_rl.ray_ablation import _subset, ablate_on_ray

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default="InvertedDoublePendulum-v5")
    p.add_argument("--min-len", type=int, default=50)
    p.add_argument("--max-len", type=int, default=300)
    p.add_argument("--cpus", type=int, default=os.cpu_count() or 1)
    args = p.parse_args()
    demos = EpisodeSet.load(ROOT / "data" / "demos" / f"{args.task}.npz")
    recorded = EpisodeSet.load(ROOT / "results" / "ablation" / args.task / "sac-bare-s0" / "episodes.npz")
    keep = [i for i in range(len(recorded)) if args.min_len <= len(recorded.episode(i)["rew"]) <= args.max_len]
    episodes = _subset(recorded, keep)
    print(f"{args.task}: {len(episodes)} episodes of {args.min_len}-{args.max_len} steps "
          f"({episodes.transitions} steps), 576 strategies, demonstrations {demos.group_sizes}")

    timings = {}
    t = time.perf_counter()
    one = defender_rl.ablate(demos, episodes, threads=1)
    timings["defender_rl.ablate, 1 thread"] = time.perf_counter() - t
    t = time.perf_counter()
    defender_rl.ablate(demos, episodes, threads=args.cpus)
    timings[f"defender_rl.ablate, {args.cpus} threads"] = time.perf_counter() - t

    import ray

    ray.init(num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
    ablate_on_ray([(demos, _subset(episodes, [0]))], strategies=["MinBoth/MinBoth"])  # starts the workers
    t = time.perf_counter()
    rows = ablate_on_ray([(demos, episodes)])
    timings[f"ablate_on_ray, local Ray with {args.cpus} CPUs"] = time.perf_counter() - t
    ray.shutdown()

    by_name = {r["strategy"]: r["score"] for r in one}
    worst = max(abs(r["score"] - by_name[r["strategy"]]) for r in rows)
    base = timings["defender_rl.ablate, 1 thread"]
    for name, s in timings.items():
        print(f"{name:45s} {s:8.1f} s   {base / s:4.2f}x")
    print(f"largest score difference, Ray against one process: {worst:.2e}")


if __name__ == "__main__":
    main()
