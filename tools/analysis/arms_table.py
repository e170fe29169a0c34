#!/usr/bin/env python3
"""The table of an experiment's arms, one row per task and arm of an `arms.txt` file
(`TASK ARM DIR...`, e.g. results/baselines/arms.txt), each row `defender report`'s figures for that
arm's run directories: the same numbers the report gives, named by arm, in one table.

  python3 tools/analysis/arms_table.py results/baselines/arms.txt
  python3 tools/analysis/arms_table.py results/velocity/arms.txt --task SafetyHopperVelocity-v1

Each cell is the mean ± std over the arm's seeds (the report's bootstrap intervals are in its own
tables). An arm listed without directories is shown as still to run. An arm whose runs the report
puts in more than one row (their configurations differ) is refused, naming it: one arm, one
configuration. The columns: seeds; crashes (on a velocity task: falls) over the run, after the
learner's warm-up, and per 1,000 environment steps; the mean of the last 10 evaluations (unfiltered; with the filter kept,
where the runs have it); on a task with an episode cost limit, the training cost rate and the
last-10 evaluation cost (both ways).

With `--shares ARM` it prints instead each arm's crashes as a share of ARM's on the same task (the
means over seeds divided), over the run and after the warm-up, one row per arm and one column per
task:

  python3 tools/analysis/arms_table.py results/baselines/arms.txt --shares bare

`--arm ARM` (repeatable) keeps only those arms. `--plots DIR` also draws their plots,
`defender report --plots DIR` on the shown arms' runs (every arm of a task in one figure per
kind):

  python3 tools/analysis/arms_table.py results/velocity/arms.txt --arm bare --arm defender-limit --plots plots/
"""

from __future__ import annotations

import argparse
import csv
import io
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def defender_binary(given: str | None) -> str:
    for candidate in (given, shutil.which("defender"), str(ROOT / "target" / "release" / "defender")):
        if candidate and Path(candidate).exists():
            return candidate
    raise SystemExit("no `defender` binary: give --defender PATH, or build it (cargo build --release -p defender-cli)")


def read_arms(path: Path) -> list[tuple[str, str, list[str]]]:
    arms = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if len(words) < 2:
            raise SystemExit(f"{path}:{number}: expected TASK ARM DIR..., found {line!r}")
        arms.append((words[0], words[1], words[2:]))
    return arms


def report_row(binary: str, dirs: list[str], where: str) -> dict[str, str]:
    done = subprocess.run([binary, "report", "--strict", "--format", "csv", *dirs], cwd=ROOT,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{where}: defender report failed:\n{done.stderr}")
    rows = list(csv.DictReader(io.StringIO(done.stdout)))
    if len(rows) != 1:
        labels = ", ".join(r["algo"] for r in rows)
        raise SystemExit(f"{where}: its runs form {len(rows)} rows of the report ({labels}), not one: "
                         "an arm's runs must share one configuration")
    return rows[0]


def cell(row: dict[str, str], name: str, decimals: int, std_decimals: int = 1) -> str:
    """`mean ± std` as the report prints it: the std to one decimal unless told."""
    mean, std = row.get(f"{name}_mean", ""), row.get(f"{name}_std", "")
    if mean == "":
        return "-"
    return f"{float(mean):.{decimals}f} ± {float(std):.{std_decimals}f}"


def share(row: dict[str, str] | None, base: dict[str, str], name: str) -> str:
    if row is None:
        return "(to run)"
    if float(base[f"{name}_mean"]) == 0:
        return "-"
    return f"{float(row[f'{name}_mean']) / float(base[f'{name}_mean']):.2f}"


def print_shares(rows: list, base_arm: str, where: Path) -> None:
    """One row per arm, one column per task: `over the run (after the warm-up)` as shares of the
    base arm's crashes on that task."""
    tasks = list(dict.fromkeys(task for task, _, _ in rows))
    arms = list(dict.fromkeys(arm for _, arm, _ in rows))
    found = {(task, arm): row for task, arm, row in rows}
    for task in tasks:
        if found.get((task, base_arm)) is None:
            raise SystemExit(f"{where}: {task} has no runs of {base_arm!r} to take shares of")
    print("| arm | " + " | ".join(tasks) + " |")
    print("| --- | " + " | ".join("---:" for _ in tasks) + " |")
    for arm in arms:
        cells = []
        for task in tasks:
            if (task, arm) not in found:
                cells.append("")
                continue
            row, base = found[(task, arm)], found[(task, base_arm)]
            over = share(row, base, "crashes")
            cells.append(over if row is None else f"{over} ({share(row, base, 'crashes_after_warmup')})")
        print(f"| {arm} | " + " | ".join(cells) + " |")


def draw_plots(binary: str, arms: list[tuple[str, str, list[str]]], out: Path, where: Path) -> None:
    """`defender report --plots` on the shown arms' runs: it draws one figure per task and kind."""
    dirs = [d for _, _, arm_dirs in arms for d in arm_dirs]
    if not dirs:
        return
    done = subprocess.run([binary, "report", "--strict", "--plots", str(out.resolve()), *dirs], cwd=ROOT,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{where}: the plots failed: {done.stderr.strip()}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("arms", type=Path, help="an arms.txt file: TASK ARM DIR... per line")
    parser.add_argument("--task", action="append", help="only this task (may be repeated)")
    parser.add_argument("--arm", action="append", help="only this arm (may be repeated)")
    parser.add_argument("--plots", type=Path, metavar="DIR",
                        help="also draw the shown arms' plots into DIR (`defender report --plots`)")
    parser.add_argument("--defender", help="the defender binary (default: on PATH, else target/release)")
    parser.add_argument("--shares", metavar="ARM",
                        help="print each arm's crashes as a share of ARM's on the same task instead")
    args = parser.parse_args()
    binary = defender_binary(args.defender)
    arms = [a for a in read_arms(args.arms)
            if (not args.task or a[0] in args.task) and (not args.arm or a[1] in args.arm)]
    if not arms:
        raise SystemExit(f"{args.arms}: no arm" + (f" named {', '.join(args.arm)}" if args.arm else "")
                         + (f" of {', '.join(args.task)}" if args.task else ""))
    rows = []
    for task, arm, dirs in arms:
        rows.append((task, arm, report_row(binary, dirs, f"{args.arms}: {task} {arm}") if dirs else None))
    if args.plots:
        draw_plots(binary, arms, args.plots, args.arms)
    if args.shares:
        print_shares(rows, args.shares, args.arms)
        return 0
    costs = any(r and r.get("episode_cost_limit") for _, _, r in rows)
    header = ["task", "arm", "seeds", "crashes", "after warm-up", "crashes / 1k env steps", "last-10 eval",
              "last-10 eval, filter kept"]
    if costs:
        header += ["cost rate", "eval cost (last-10)", "eval cost, filter kept"]
    print("| " + " | ".join(header) + " |")
    print("| --- | --- | " + " | ".join("---:" for _ in header[2:]) + " |")
    for task, arm, row in rows:
        if row is None:
            print(f"| {task} | {arm} | (to run) |" + " |" * (len(header) - 3))
            continue
        cells = [task, arm, row["n_seeds"], cell(row, "crashes", 0), cell(row, "crashes_after_warmup", 0),
                 cell(row, "crashes_per_1k_env_steps", 2), cell(row, "last10_eval", 0),
                 cell(row, "shield_eval_last10", 0)]
        if costs:
            cells += [cell(row, "cost_rate", 3, 3), cell(row, "eval_cost_last10", 1),
                      cell(row, "shield_eval_cost_last10", 1)]
        print("| " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
