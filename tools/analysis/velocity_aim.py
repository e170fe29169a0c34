#!/usr/bin/env python3
"""Whether the velocity tasks' aim is met, per task of an `arms.txt` file (results/velocity/arms.txt): a
DEFENDER arm (the candidate, `defender-limit`) whose policy, evaluated without the filter, keeps
the episode cost limit (the mean of the last 10 evaluations' episode cost at most the limit) with
a higher last-10 return than the best Lagrangian's, while its training cost rate is at most half
of that Lagrangian's.

  python3 tools/analysis/velocity_aim.py results/velocity/arms.txt
  python3 tools/analysis/velocity_aim.py results/velocity/arms.txt --lagrangians lagrangian pid

The *best Lagrangian* is chosen as the screen's rule chose it (docs/decisions-velocity.md): of the
Lagrangian arms, the one with the highest last-10 return among those whose last-10 evaluation
cost keeps the limit, else the one with the lowest evaluation cost. By default the Lagrangian arms
are the repaired Lagrangian SAC, PID and OmniSafe's SACLag (`lagrangian pid omnisafe-saclag`).
Every figure is the mean over the arm's seeds of `defender report`'s per-run value (the same
numbers as tools/analysis/arms_table.py); the verdict says how many seeds it rests on, "not yet" while
an arm it needs has no runs, and "provisional" while a Lagrangian arm still to run could change
it (a candidate over the limit misses the aim whatever they give).

The aim is also judged by the share of evaluation episodes within the limit (docs/decisions-velocity.md,
"The aim by the share of episodes within the limit"): the first condition read per episode, the
candidate's share of last-10 evaluation episodes whose cost is at most the limit at least the best
Lagrangian's and at least one half; the other two conditions as they are. Each figure carries the
report's 95% bootstrap interval over seeds, and the verdict says where the interval of the
candidate's evaluation cost holds the limit (its seeds do not settle which side it is on).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from arms_table import defender_binary, read_arms, report_row  # noqa: E402

DEFAULT_LAGRANGIANS = ["lagrangian", "pid", "omnisafe-saclag"]


@dataclass(frozen=True)
class Arm:
    name: str
    seeds: int
    eval_return: float  # mean of the last 10 evaluations' return, without the filter
    eval_cost: float  # the same evaluations' mean episode cost
    cost_rate: float  # training cost / training environment steps
    eval_cost_ci: tuple[float, float] = (float("nan"), float("nan"))  # 95% bootstrap over seeds
    within: float = float("nan")  # share of the last-10 evaluation episodes with cost <= the limit
    within_ci: tuple[float, float] = (float("nan"), float("nan"))


def best_lagrangian(arms: list[Arm], limit: float) -> Arm:
    """The screen's rule: the highest return among those within the limit, else the lowest cost."""
    within = [a for a in arms if a.eval_cost <= limit]
    if within:
        return max(within, key=lambda a: a.eval_return)
    return min(arms, key=lambda a: a.eval_cost)


def return_and_rate(candidate: Arm, best: Arm) -> tuple[bool, bool]:
    """The aim's second and third conditions, shared by both readings of its first: a higher
    return than `best`'s, at a training cost rate at most half of `best`'s."""
    return candidate.eval_return > best.eval_return, candidate.cost_rate <= 0.5 * best.cost_rate


def verdict(candidate: Arm, best: Arm, limit: float) -> tuple[bool, list[str]]:
    """Whether the aim is met, and each of its three conditions as a line."""
    keeps = candidate.eval_cost <= limit
    higher, cheap = return_and_rate(candidate, best)
    bound = 0.5 * best.cost_rate
    lines = [
        f"evaluation cost {candidate.eval_cost:.1f} {'<=' if keeps else '>'} the limit {limit:g}",
        f"return {candidate.eval_return:.0f} {'>' if higher else '<='} {best.name}'s {best.eval_return:.0f}",
        f"training cost rate {candidate.cost_rate:.3f} {'<=' if cheap else '>'} half {best.name}'s "
        f"({best.cost_rate:.3f} / 2 = {bound:.3f})",
    ]
    return keeps and higher and cheap, lines


def share_verdict(candidate: Arm, best: Arm) -> tuple[bool, str]:
    """The aim by the share of episodes within the limit: the first condition read per episode
    (at least the best Lagrangian's share and at least one half), the other two as `verdict`'s."""
    enough = candidate.within >= best.within and candidate.within >= 0.5
    line = (f"episodes within the limit {candidate.within:.0%} {'>=' if candidate.within >= best.within else '<'} "
            f"{best.name}'s {best.within:.0%}, {'>=' if candidate.within >= 0.5 else '<'} one half")
    higher, cheap = return_and_rate(candidate, best)
    return enough and higher and cheap, line


def straddles(candidate: Arm, limit: float) -> bool:
    """Whether the interval of the candidate's evaluation cost holds the limit."""
    lo, hi = candidate.eval_cost_ci
    return lo <= limit <= hi


def pending(candidate: Arm, missing: list[str], limit: float, seeds: int) -> str:
    """What the runs still to come leave open, as a suffix of the verdict; `seeds` is the most
    seeds any arm of the task has."""
    if candidate.seeds < seeds:
        # The candidate's own mean can still cross the limit: nothing is settled yet.
        rest = f"; {', '.join(missing)} not yet run" if missing else ""
        return f" (provisional: {candidate.name} has {candidate.seeds} of {seeds} seeds{rest})"
    if not missing:
        return ""
    if candidate.eval_cost > limit:
        # The limit is the candidate's own condition: no Lagrangian still to run can meet it.
        return f" (whatever {', '.join(missing)} give{'s' if len(missing) == 1 else ''}: over the limit)"
    return f" (provisional: {', '.join(missing)} not yet run)"


def figure(row: dict[str, str], name: str) -> float:
    """A report figure, NaN where the report leaves it empty (runs made before it was recorded)."""
    value = row.get(name, "")
    return float(value) if value != "" else float("nan")


def arm_of(name: str, row: dict[str, str], where: str) -> Arm:
    try:
        return Arm(name, int(row["n_seeds"]), float(row["last10_eval_mean"]), float(row["eval_cost_last10_mean"]),
                   float(row["cost_rate_mean"]),
                   (figure(row, "eval_cost_last10_ci_lo"), figure(row, "eval_cost_last10_ci_hi")),
                   figure(row, "eval_within_limit_last10_mean"),
                   (figure(row, "eval_within_limit_last10_ci_lo"), figure(row, "eval_within_limit_last10_ci_hi")))
    except (KeyError, ValueError) as e:
        raise SystemExit(f"{where}: the report gives no cost figures ({e}): is this a task with an episode cost limit?")


def describe(arm: Arm) -> str:
    lo, hi = arm.eval_cost_ci
    w_lo, w_hi = arm.within_ci
    within = "" if math.isnan(arm.within) else f", episodes within the limit {arm.within:.0%} [{w_lo:.0%}, {w_hi:.0%}]"
    return (f"- {arm.name} ({arm.seeds} seed{'s' if arm.seeds != 1 else ''}): last-10 return {arm.eval_return:.0f}, "
            f"evaluation cost {arm.eval_cost:.1f} [{lo:.1f}, {hi:.1f}]{within}, training cost rate {arm.cost_rate:.3f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("arms", type=Path, help="an arms.txt file: TASK ARM DIR... per line")
    parser.add_argument("--candidate", default="defender-limit", help="the DEFENDER arm held to the aim")
    parser.add_argument("--lagrangians", nargs="+", default=DEFAULT_LAGRANGIANS, help="the Lagrangian arms")
    parser.add_argument("--task", action="append", help="only this task (may be repeated)")
    parser.add_argument("--defender", help="the defender binary (default: on PATH, else target/release)")
    args = parser.parse_args()
    binary = defender_binary(args.defender)
    listed = [a for a in read_arms(args.arms) if not args.task or a[0] in args.task]
    tasks = list(dict.fromkeys(t for t, arm, _ in listed if arm == args.candidate))
    if not tasks:
        raise SystemExit(f"{args.arms}: no arm named {args.candidate!r}")
    for task in tasks:
        print(f"## {task}")
        wanted = [args.candidate, *args.lagrangians]
        arms, missing, limit = {}, [], None
        for t, name, dirs in listed:
            if t != task or name not in wanted:
                continue
            if not dirs:
                missing.append(name)
                continue
            where = f"{args.arms}: {task} {name}"
            row = report_row(binary, dirs, where)
            if row.get("episode_cost_limit"):
                limit = float(row["episode_cost_limit"])
            arms[name] = arm_of(name, row, where)
        missing += [n for n in wanted if n not in arms and n not in missing]
        for arm in arms.values():
            print(describe(arm))
        if args.candidate in missing or not [n for n in args.lagrangians if n in arms]:
            print(f"- **not yet**: no runs of {', '.join(missing)}\n")
            continue
        if limit is None:
            raise SystemExit(f"{args.arms}: {task}: no episode cost limit in the runs' configuration")
        best = best_lagrangian([arms[n] for n in args.lagrangians if n in arms], limit)
        met, lines = verdict(arms[args.candidate], best, limit)
        seeds = sorted({a.seeds for a in arms.values()})
        print(f"- best Lagrangian: {best.name}")
        for line in lines:
            print(f"  - {line}")
        provisional = pending(arms[args.candidate], missing, limit, max(seeds))
        print(f"- **aim {'met' if met else 'not met'}**, on {'/'.join(map(str, seeds))} seeds{provisional}")
        candidate = arms[args.candidate]
        if straddles(candidate, limit):
            print(f"  - the interval of {candidate.name}'s evaluation cost holds the limit: its seeds do not settle "
                  "which side it is on")
        if not (math.isnan(candidate.within) or math.isnan(best.within)):
            by_share, line = share_verdict(candidate, best)
            print(f"- by the share of episodes within the limit: **{'met' if by_share else 'not met'}** ({line})")
        else:
            print("- by the share of episodes within the limit: - (runs without eval_episodes.csv)")
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
