#!/usr/bin/env python3
"""The bar of "a filter that keeps learning", recomputed from committed run directories.

    python3 scripts/keeps_learning_bar.py results/keeps-learning
    python3 scripts/keeps_learning_bar.py results/keeps-learning --chosen chosen-demos.txt

`chosen.txt` in that folder (or the file `--chosen` names there: one file per configuration
fixed before its runs) names, one line per task, the run directories (relative to the
folder) of the configuration fixed before the runs; the bare runs it is held against are the
task's `sac-bare-s<seed>` directories beside them. Per task the configuration passes when, as
means over its seeds:

- % Crash over the whole run (crashed / all training episodes, metrics.csv) is at most a third
  of bare SAC's;
- the mean of the last 10 evaluations (eval.csv) is at least 90% of bare SAC's;
- no evaluation stands still (every episode lasted the horizon and the mean return is within
  10% of the mean length: the healthy reward alone; `defender report`'s "Standing %").

Runs without a complete summary.json are listed and the verdict is withheld. Standard library
only.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path
from statistics import mean

HORIZON = 1000  # Hopper-v5, Walker2d-v5 and InvertedDoublePendulum-v5
LAST = 10
TOLERANCE = 0.1


def measures(run: Path) -> dict:
    with open(run / "metrics.csv", newline="") as f:
        outcomes = [r["outcome"] for r in csv.DictReader(f)]
    with open(run / "eval.csv", newline="") as f:
        evals = [(float(r["mean_return"]), float(r["mean_length"])) for r in csv.DictReader(f)]
    summary = json.loads((run / "summary.json").read_text()) if (run / "summary.json").exists() else {}
    standing = sum(1 for ret, length in evals if length >= HORIZON and abs(ret - length) <= TOLERANCE * length)
    return {
        "complete": bool(summary.get("complete")),
        "crash": 100.0 * outcomes.count("crashed") / max(len(outcomes), 1),
        "last10": mean(ret for ret, _ in evals[-LAST:]) if evals else float("nan"),
        "standing": standing,
        "evals": len(evals),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--chosen", default="chosen.txt", help="the configuration's file in FOLDER [default: chosen.txt]")
    args = parser.parse_args()
    lines = (args.folder / args.chosen).read_text().split("\n")
    verdicts = []
    print("| task | runs | % Crash | bare % Crash | last-10 eval | bare last-10 | standing evals | verdict |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |")
    for line in filter(None, (l.strip() for l in lines)):
        chosen = [args.folder / d for d in line.split()]
        task = chosen[0].parent
        bare = sorted(task.glob("sac-bare-s*"))
        missing = [r for r in chosen + bare if not (r / "summary.json").exists()]
        present = [r for r in chosen + bare if r not in missing]
        got = {r: measures(r) for r in present}
        incomplete = missing + [r for r, m in got.items() if not m["complete"]]
        if incomplete:
            names = ", ".join(str(r.relative_to(args.folder)) for r in incomplete)
            print(f"| {task.name} | {len(chosen)} | - | - | - | - | - | withheld: not complete: {names} |")
            verdicts.append(None)
            continue
        c = [got[r] for r in chosen]
        b = [got[r] for r in bare]
        crash, bare_crash = mean(m["crash"] for m in c), mean(m["crash"] for m in b)
        last, bare_last = mean(m["last10"] for m in c), mean(m["last10"] for m in b)
        standing = sum(m["standing"] for m in c)
        fails = []
        if crash > bare_crash / 3:
            fails.append("crashes above a third of bare's")
        if last < 0.9 * bare_last:
            fails.append("last-10 eval below 90% of bare's")
        if standing:
            fails.append(f"{standing} standing evaluation(s)")
        verdict = "passes" if not fails else "fails: " + "; ".join(fails)
        verdicts.append(not fails)
        print(
            f"| {task.name} | {len(chosen)} vs {len(bare)} bare | {crash:.1f} | {bare_crash:.1f} | {last:.0f} | "
            f"{bare_last:.0f} | {standing} of {sum(m['evals'] for m in c)} | {verdict} |"
        )
    if None in verdicts:
        print("\nverdict withheld: some runs are not complete", file=sys.stderr)
        return 2
    print("\nthe bar holds on every task" if all(verdicts) else "\nthe bar does not hold on every task")
    return 0 if all(verdicts) else 1


if __name__ == "__main__":
    sys.exit(main())
