#!/usr/bin/env python3
"""Applies a screen's written rule to its committed runs and prints a table per task.

The rules are docs/decisions-baselines.md ("The second screen of the baselines' knobs")
and docs/decisions-velocity.md ("The screen" and "The screen at power"), each written before
its runs. This only reads run directories (metrics.csv, eval.csv, eval_episodes.csv,
config.toml, interventions.csv); it trains nothing.

  python3 tools/analysis/screen_rule.py baselines results/screen-baselines results/screen-baselines-recovery \
      --bare results/keeps-learning
  python3 tools/analysis/screen_rule.py baselines results/screen-triggers --bare results/keeps-learning \
      --reference sac-auto-precision-demos
  python3 tools/analysis/screen_rule.py velocity results/velocity-limit-screen
  python3 tools/analysis/screen_rule.py velocity results/velocity-power-screen

A run directory is TASK/NAME-sSEED; a setting is NAME without its seed. The budget is read from
each run's config.toml (total_steps); runs still under way are reported as such and left out.
"""

from __future__ import annotations

import argparse
import csv
import re
import statistics
import sys
import tomllib
from pathlib import Path

WARMUP = 5000  # SAC's random steps: no baseline acts before them
LATE = 0.6  # the evaluations in the last 40% of the budget
BAR = 0.8  # the baselines' bar: 80% of bare SAC's return
LIMIT = 25.0  # the velocity tasks' episode cost limit


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def budget(run: Path) -> int:
    return int(tomllib.loads((run / "config.toml").read_text())["total_steps"])


def late_eval(run: Path, steps: int, column: str) -> float:
    """The mean of `column` over the evaluations at or after 60% of `steps`, up to `steps`."""
    values = [float(r[column]) for r in rows(run / "eval.csv") if LATE * steps <= int(r["total_steps"]) <= steps]
    if not values:
        raise SystemExit(f"{run}: no evaluation between {LATE * steps:.0f} and {steps} steps")
    return sum(values) / len(values)


def complete(run: Path, steps: int) -> bool:
    evals = rows(run / "eval.csv") if (run / "eval.csv").exists() else []
    return any(int(r["total_steps"]) >= steps for r in evals)


def episodes_after_warmup(run: Path, steps: int, outcome: str) -> int:
    return sum(
        1
        for r in rows(run / "metrics.csv")
        if r["outcome"] == outcome and WARMUP < int(r["total_steps"]) <= steps
    )


def crashes_after_warmup(run: Path, steps: int) -> int:
    return episodes_after_warmup(run, steps, "crashed")


def cost_rate(run: Path, steps: int) -> float:
    """The task's cost over the environment steps (a filtered step reaches no environment)."""
    cost = env_steps = 0.0
    for r in rows(run / "metrics.csv"):
        if int(r["total_steps"]) > steps:
            break
        cost += float(r["cost"])
        env_steps += int(r["length"]) - (1 if r["outcome"] == "filtered" else 0)
    return cost / env_steps


def settings(*roots: Path) -> dict[str, dict[str, list[Path]]]:
    """task -> setting -> its run directories, over the screen's directories (one sweep's each)."""
    out: dict[str, dict[str, list[Path]]] = {}
    for root in roots:
        if not root.is_dir():
            raise SystemExit(f"{root}: not a directory (a screen's sweep directory holds TASK/NAME-sSEED runs)")
    for run in sorted(run for root in roots for run in root.glob("*/*-s[0-9]*")):
        if not (run / "config.toml").exists():
            continue
        name = re.sub(r"-s\d+$", "", run.name)
        out.setdefault(run.parent.name, {}).setdefault(name, []).append(run)
    return out


def interventions(run: Path, steps: int) -> tuple[int, int, list[int]] | None:
    """(interventions after the warm-up, of them checked, the steps to failure of those that would
    have failed), from interventions.csv (docs/run-directory.md); None for a run without one."""
    path = run / "interventions.csv"
    if not path.exists():
        return None
    late = [r for r in rows(path) if WARMUP < int(r["total_steps"]) <= steps]
    checked = [r for r in late if r["checked"] == "1"]
    return len(late), len(checked), [int(r["steps_to_failure"]) for r in checked if r["would_fail"] == "1"]


def reference_line(task_dir: Path, name: str, seeds: list[int], steps: int) -> str:
    """A committed arm's runs on the screen's seeds read to the screen's budget the same way (the
    default beside a screen of other triggers): not a setting of the screen, so outside the rule."""
    runs = [task_dir / f"{name}-s{s}" for s in seeds]
    missing = [str(r) for r in runs if not complete(r, steps)]
    if missing:
        raise SystemExit(f"--reference {name}: no run reaching {steps} steps at {', '.join(missing)}")
    crashes = [crashes_after_warmup(r, steps) for r in runs]
    filtered = [episodes_after_warmup(r, steps, "filtered") for r in runs]
    ret = mean([late_eval(r, steps, "mean_return") for r in runs])
    return (f"- reference {name}, read to {steps} steps: {mean(crashes):.1f} crashes after the warm-up "
            f"({', '.join(map(str, crashes))}), return {ret:.0f}, {mean(filtered):.1f} filtered episodes "
            f"after the warm-up ({', '.join(map(str, filtered))})\n")


def mean(xs: list[float]) -> float:
    return sum(xs) / len(xs)


def baselines(args: argparse.Namespace) -> None:
    for task, by_setting in settings(*map(Path, args.roots)).items():
        steps = budget(next(iter(by_setting.values()))[0])
        seeds = sorted({int(run.name.rsplit("-s", 1)[1]) for runs in by_setting.values() for run in runs})
        bare_runs = [Path(args.bare) / task / f"sac-bare-s{s}" for s in seeds]
        bare = mean([late_eval(r, steps, "mean_return") for r in bare_runs])
        bar = BAR * bare
        bare_crashes = mean([crashes_after_warmup(r, steps) for r in bare_runs])
        print(f"\n### {task}: {steps} steps, seeds {seeds}; bare SAC {bare:.0f} (bar {bar:.0f}), "
              f"{bare_crashes:.0f} crashes after the warm-up\n")
        for name in args.reference:
            print(reference_line(Path(args.bare) / task, name, seeds, steps))
        counted = any((r / "interventions.csv").exists() for runs in by_setting.values() for r in runs)
        extra = " interventions after warm-up | precision | lead (median steps) |" if counted else ""
        print(f"| setting | runs | crashes after warm-up | return (last 40%) | reaches the bar |{extra}")
        print("| --- | ---: | ---: | ---: | --- |" + (" ---: | ---: | ---: |" if counted else ""))
        table = []
        for name, runs in sorted(by_setting.items()):
            done = [r for r in runs if complete(r, steps)]
            if len(done) < len(seeds):
                print(f"| {name} | {len(done)} of {len(seeds)} | (under way) | | |")
                continue
            crashes = mean([crashes_after_warmup(r, steps) for r in done])
            ret = mean([late_eval(r, steps, "mean_return") for r in done])
            table.append((name, crashes, ret))
            cells = ""
            if counted:
                found = [c for c in (interventions(r, steps) for r in done) if c is not None]
                n = mean([c[0] for c in found]) if found else 0.0
                checked, leads = sum(c[1] for c in found), sorted(x for c in found for x in c[2])
                precision = f"{len(leads) / checked:.2f}" if checked else "-"
                lead = f"{statistics.median(leads):g}" if leads else "-"
                cells = f" {n:.1f} | {precision} | {lead} |"
            print(f"| {name} | {len(done)} | {crashes:.1f} | {ret:.0f} | {'yes' if ret >= bar else 'no'} |{cells}")
        families: dict[str, list[tuple[str, float, float]]] = {}
        for entry in table:
            # The setting's name without the algorithm and `bare` or the (unread) strategy.
            family = re.sub(r"^sac-(bare|[A-Z]\w*-[A-Z]\w*)-", "", entry[0]).split("-")[0].rstrip("0123456789")
            families.setdefault(family, []).append(entry)
        for family, entries in sorted(families.items()):
            above = [e for e in entries if e[2] >= bar]
            if above:
                fewest = min(e[1] for e in above)
                near = [e for e in above if e[1] <= fewest * 1.02]
                choice = max(near, key=lambda e: e[2])
                why = "the fewest crashes above the bar"
            else:
                choice = max(entries, key=lambda e: e[2])
                why = "none reaches the bar: the highest return"
            print(f"\n- {family}: **{choice[0]}** ({why}; of the settings complete on every seed)")


def late_share_within(run: Path, steps: int) -> float | None:
    """The share of the evaluation episodes at or after 60% of `steps` whose cost is at most the
    limit, from eval_episodes.csv (None for a run that predates it)."""
    path = run / "eval_episodes.csv"
    if not path.exists():
        return None
    costs = [float(r["cost"]) for r in rows(path) if LATE * steps <= int(r["total_steps"]) <= steps]
    return sum(c <= LIMIT for c in costs) / len(costs) if costs else None


def velocity(args: argparse.Namespace) -> None:
    for task, by_setting in settings(Path(args.root)).items():
        steps = budget(next(iter(by_setting.values()))[0])
        measured = {}
        print(f"\n### {task}: {steps} steps\n")
        print("| setting | runs | eval cost | eval return | training cost rate | shielded eval cost | episodes within 25 |")
        print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
        for name, runs in sorted(by_setting.items()):
            done = [r for r in runs if complete(r, steps)]
            if not done or len(done) < len(runs):
                print(f"| {name} | {len(done)} of {len(runs)} | (under way) | | | | |")
                continue
            ec = mean([late_eval(r, steps, "mean_cost") for r in done])
            er = mean([late_eval(r, steps, "mean_return") for r in done])
            cr = mean([cost_rate(r, steps) for r in done])
            shielded = [r for r in done if rows(r / "eval.csv")[-1].get("shield_mean_cost")]
            sc = f"{mean([late_eval(r, steps, 'shield_mean_cost') for r in shielded]):.1f}" if shielded else "-"
            shares = [x for x in (late_share_within(r, steps) for r in done) if x is not None]
            share = f"{100 * mean(shares):.0f}%" if len(shares) == len(done) else "-"
            measured[name] = (ec, er, cr)
            print(f"| {name} | {len(done)} | {ec:.1f} | {er:.0f} | {cr:.3f} | {sc} | {share} |")
        # The references are the bare Lagrangian and PID arms the screen holds (`lag`, and `pid`
        # where it ran one); the variants are DEFENDER's (`sac-auto-...`). The rule waits for every
        # setting of the screen.
        refs = {n: m for n, m in measured.items() if n in ("sac-bare-lag", "sac-bare-pid")}
        variants = {n: m for n, m in measured.items() if n.startswith("sac-auto-")}
        if not refs or not variants or len(measured) < len(by_setting):
            print("\n(the rule waits for every setting, a reference and a variant among them)")
            continue
        within = [(n, m) for n, m in refs.items() if m[0] <= LIMIT]
        best = max(within, key=lambda x: x[1][1]) if within else min(refs.items(), key=lambda x: x[1][0])
        bound = 0.5 * best[1][2]
        ok = [(n, m) for n, m in variants.items() if m[0] <= LIMIT and m[2] <= bound]
        if ok:
            choice, why = max(ok, key=lambda x: x[1][1]), "qualifies with the highest return"
        else:
            inside = [(n, m) for n, m in variants.items() if m[2] <= bound]
            pool = inside or list(variants.items())
            choice = min(pool, key=lambda x: x[1][0])
            why = "none qualifies: the lowest evaluation cost" + (" within the bound" if inside else "")
        print(f"\n- best Lagrangian: {best[0]} (training cost rate {best[1][2]:.3f}, bound {bound:.3f})")
        print(f"- chosen: **{choice[0]}** ({why})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="screen", required=True)
    b = sub.add_parser("baselines", help="the second screen of the baselines' knobs")
    b.add_argument("roots", nargs="+", help="the screen's sweep directories (TASK/NAME-sSEED runs)")
    b.add_argument("--bare", required=True, help="the directory with TASK/sac-bare-sSEED runs")
    b.add_argument(
        "--reference",
        action="append",
        default=[],
        metavar="NAME",
        help="also read the --bare directory's TASK/NAME-sSEED runs to the screen's budget, for comparison "
        "(outside the rule; e.g. sac-auto-precision-demos, the default)",
    )
    v = sub.add_parser("velocity", help="the velocity tasks' screen of the DEFENDER variants")
    v.add_argument("root")
    args = parser.parse_args()
    {"baselines": baselines, "velocity": velocity}[args.screen](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
