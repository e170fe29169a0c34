#!/usr/bin/env python3
"""How a run's crash rate and evaluation return move as it trains: per window of steps, the
episodes that ended in it, the share that crashed and that the filter ended, and the
evaluation returns inside it (their mean, and the last one). A Markdown table, one row per run
directory and window.

    python3 scripts/crash_by_window.py results/budget-hopper/Hopper-v5/* --window 100000

Reads a run directory's metrics.csv and eval.csv (docs/run-directory.md); incomplete runs are
read as far as they go. Standard library only.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path


def windows(run: Path, width: int) -> list[tuple[int, int, float, float, str, str]]:
    """(window start, episodes, % crashed, % filtered, mean and last evaluation return) per
    window; a single evaluation is noisy (SAC on Hopper-v5 can fall from 3000 to 800 between
    two of them), the mean over a window less so."""
    with open(run / "metrics.csv", newline="") as f:
        episodes = [(int(r["total_steps"]), r["outcome"]) for r in csv.DictReader(f)]
    evals: list[tuple[int, float]] = []
    if (run / "eval.csv").exists():
        with open(run / "eval.csv", newline="") as f:
            evals = [(int(r["total_steps"]), float(r["mean_return"])) for r in csv.DictReader(f)]
    if not episodes:
        return []
    rows = []
    last = episodes[-1][0]
    for start in range(0, last, width):
        # An episode belongs to the window its last step falls in; an evaluation at the window's
        # end (step 100000 of [0, 100000]) belongs to it too.
        inside = [o for s, o in episodes if start < s <= start + width]
        n = len(inside)
        crashed = 100.0 * sum(o == "crashed" for o in inside) / n if n else 0.0
        filtered = 100.0 * sum(o == "filtered" for o in inside) / n if n else 0.0
        in_window = [r for s, r in evals if start < s <= start + width]
        mean = f"{sum(in_window) / len(in_window):.0f}" if in_window else "-"
        rows.append((start, n, crashed, filtered, mean, f"{in_window[-1]:.0f}" if in_window else "-"))
    return rows


def steps(n: int, window: int) -> str:
    """A window bound: in thousands (`100k`) when windows are whole thousands."""
    return f"{n // 1000}k" if window % 1000 == 0 else str(n)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories")
    parser.add_argument("--window", type=int, default=100_000, help="steps per window [default: 100000]")
    args = parser.parse_args()
    if args.window <= 0:
        parser.error(f"--window must be positive, got {args.window}")
    print("| run | steps | episodes | % crash | % filtered | eval return: mean | last |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for run in args.runs:
        if not (run / "metrics.csv").exists():
            print(f"error: {run}: no metrics.csv (not a run directory)", file=sys.stderr)
            return 1
        for start, n, crashed, filtered, mean, last in windows(run, args.window):
            span = f"{steps(start, args.window)}-{steps(start + args.window, args.window)}"
            print(f"| {'/'.join(run.parts[-3:])} | {span} | {n} | {crashed:.1f} | {filtered:.1f} | {mean} | {last} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
