#!/usr/bin/env python3
"""What a run's constraint learner saw against what its policy pays once deployed: per run, the
mean episode cost of the last N training episodes as the task counts it and as the learner was
charged it, the share of those episodes each outcome ended, and the mean of the last 10
evaluations' episode cost (the policy without the filter).

  python3 tools/analysis/learner_cost.py results/velocity/SafetyHopperVelocity-v1/sac-auto-defender-limit-s*

With `[defender] filtered_cost = "violation"` (docs/SPEC.md section 14) a filtered episode costs the
learner `max(C, L + 1)`, C the task's cost of its executed steps and L the episode cost limit;
otherwise the learner is charged the task's cost. A Lagrangian's `J_c` is this charged mean over
its window (50 episodes by default): where it sits under the limit while the evaluation cost is
over it, the learner was told it kept a limit that its policy, unfiltered, does not.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path


@dataclass
class Seen:
    run: str
    episodes: int
    task_cost: float  # mean episode cost, the task's count
    learner_cost: float  # mean episode cost, as charged to the learner
    outcomes: dict[str, float]  # share of the episodes each outcome ended
    eval_cost: float  # mean of the last 10 evaluations' episode cost, unfiltered


def read_csv(path: Path) -> list[dict[str, str]]:
    try:
        with path.open(newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        raise SystemExit(f"{path}: cannot read ({e.strerror})") from None


def charge_of(config: dict, where: Path) -> float | None:
    """The cost a filtered episode reaches for the learner (L + 1), or None when uncharged."""
    defender = config.get("defender") or {}
    if defender.get("filtered_cost", "none") != "violation":
        return None
    limit = defender.get("episode_cost_limit")
    if limit is None:
        raise SystemExit(f"{where}: filtered_cost is \"violation\" but [defender] has no episode_cost_limit")
    return float(limit) + 1.0


def seen(run: Path, last: int) -> Seen:
    try:
        config = tomllib.loads((run / "config.toml").read_text())
    except OSError as e:
        raise SystemExit(f"{run / 'config.toml'}: cannot read ({e.strerror})") from None
    except tomllib.TOMLDecodeError as e:
        raise SystemExit(f"{run / 'config.toml'}: not TOML ({e})") from None
    charge = charge_of(config, run / "config.toml")
    episodes = read_csv(run / "metrics.csv")[-last:]
    evals = read_csv(run / "eval.csv")[-10:]
    if not episodes or not evals:
        raise SystemExit(f"{run}: no training episodes or no evaluations yet")
    try:
        task = [float(e["cost"]) for e in episodes]
        ends = [e["outcome"] for e in episodes]
        eval_cost = sum(float(e["mean_cost"]) for e in evals) / len(evals)
    except (KeyError, ValueError) as e:
        raise SystemExit(f"{run}: no per-episode costs ({e}): is this a run on a task with costs?") from None
    learner = [max(c, charge) if charge is not None and end == "filtered" else c for c, end in zip(task, ends)]
    outcomes = {o: ends.count(o) / len(ends) for o in sorted(set(ends))}
    return Seen(str(run), len(episodes), sum(task) / len(task), sum(learner) / len(learner), outcomes, eval_cost)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="run directories (config.toml, metrics.csv, eval.csv)")
    parser.add_argument("--last", type=int, default=50,
                        help="how many last training episodes (default 50: a Lagrangian's default window)")
    args = parser.parse_args()
    if args.last < 1:
        parser.error("--last must be at least 1")
    rows = [seen(run, args.last) for run in args.runs]
    print("| run | episodes | task's cost | learner's cost | filtered | crashed | truncated | last-10 eval cost |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for s in rows:
        shares = " | ".join(f"{100 * s.outcomes.get(o, 0.0):.0f}%" for o in ("filtered", "crashed", "truncated"))
        print(f"| {s.run} | {s.episodes} | {s.task_cost:.1f} | {s.learner_cost:.1f} | {shares} | {s.eval_cost:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
