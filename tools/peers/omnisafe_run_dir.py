#!/usr/bin/env python3
"""Turn the output of tools/peers/omnisafe_saclag.py into a run directory that `defender report` reads.

OmniSafe's SACLag is a peer (docs/peers.md): its run is not ours, but its curve and measures
belong in the same table and plots as our arms of the velocity tasks. This writes, into the
OmniSafe output folder OUT (beside episodes.csv, evals.csv, run.json and OmniSafe's own logs),
the four files of a run directory (docs/run-directory.md), each atomically:

  config.toml   env, algo = "sac", seed, the budget, and a [peer] table naming OmniSafe, its
                versions and its cost limit: `defender report` labels the row
                `SAC (omnisafe-saclag)`; nothing of ours can train from this file.
  metrics.csv   one row per training episode of episodes.csv. outcome: an episode shorter than
                the horizon (1,000) ended by the task's health termination ("crashed"); one of
                1,000 steps was truncated.
  eval.csv      OmniSafe evaluates one deterministic episode at the end of each epoch (2,000
                steps; evals.csv); they are grouped by --eval-every steps of training (default
                10,000, our runs' evaluation interval), one row per group at its end: the mean,
                std, mean length and mean cost of its episodes (5 per row at the defaults, as
                our runs of experiments/velocity.toml evaluate 5 every 10,000 steps).
  summary.json  the totals, as `defender train` writes them, with the task's episode cost limit.

Only a finished run converts (run.json's "complete": true).
Stdlib only (it runs on the project's Python or OmniSafe's venv):
    python3 tools/peers/omnisafe_run_dir.py results/velocity/omnisafe/hopper-s0
tools/peers/omnisafe_saclag.py calls it when training ends. A second call rewrites the four files from
the same inputs, identically.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import statistics
import sys

HORIZON = 1000
PEER = "omnisafe-saclag"
EPISODE_COLUMNS = ["episode", "total_steps", "return", "length", "cost", "wall_seconds"]
EVAL_COLUMNS = ["total_steps", "return", "length", "cost", "wall_seconds"]


class InputError(Exception):
    """An input file is missing or malformed; the message names it."""


def write_atomic(path: str, text: str) -> None:
    tmp = f"{path}.tmp"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_json(path: str, value: dict) -> None:
    write_atomic(path, json.dumps(value, indent=2) + "\n")


def read_rows(path: str, columns: list[str]) -> list[dict[str, float]]:
    """The rows of a CSV file, every one of `columns` a finite number."""
    if not os.path.exists(path):
        raise InputError(f"{path}: missing")
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in columns if c not in (reader.fieldnames or [])]
        if missing:
            raise InputError(f"{path}: no column {', '.join(missing)} (header: {reader.fieldnames})")
        return [{c: number(path, i + 2, r, c) for c in columns} for i, r in enumerate(reader)]


def number(path: str, line: int, row: dict[str, str], column: str) -> float:
    try:
        value = float(row[column])
    except (TypeError, ValueError):
        raise InputError(f"{path}:{line}: column {column}: {row[column]!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{path}:{line}: column {column}: {value} is not finite")
    return value


def convert(out: str, eval_every: int) -> dict:
    run_path = os.path.join(out, "run.json")
    if not os.path.exists(run_path):
        raise InputError(f"{run_path}: missing (is {out} an output folder of tools/peers/omnisafe_saclag.py?)")
    with open(run_path, encoding="utf-8") as f:
        run = json.load(f)
    for key in ("env", "seed", "steps", "cost_limit", "versions", "complete"):
        if key not in run:
            raise InputError(f"{run_path}: no key {key!r}")
    if run["complete"] is not True:
        raise InputError(f'{run_path}: "complete" is not true: the run did not finish (only a finished run converts)')
    env_steps = int(run["steps"])

    ep_path = os.path.join(out, "episodes.csv")
    episodes = read_rows(ep_path, EPISODE_COLUMNS)
    metrics = ["episode,total_steps,return,length,outcome,wall_seconds,cost"]
    crashed = 0
    for i, e in enumerate(episodes):
        length = int(e["length"])
        if e["episode"] != i:
            raise InputError(f"{ep_path}:{i + 2}: episode {e['episode']:.0f} out of order: expected {i}")
        if not 0 < length <= HORIZON:
            raise InputError(f"{ep_path}:{i + 2}: length {length} outside 1..{HORIZON}")
        outcome = "crashed" if length < HORIZON else "truncated"
        crashed += outcome == "crashed"
        metrics.append(
            f"{i},{int(e['total_steps'])},{e['return']!r},{length},{outcome},{e['wall_seconds']:.3f},{e['cost']!r}"
        )
    total_cost = math.fsum(e["cost"] for e in episodes)

    ev_path = os.path.join(out, "evals.csv")
    groups: dict[int, list[dict[str, float]]] = {}
    for e in read_rows(ev_path, EVAL_COLUMNS):
        end = min(math.ceil(e["total_steps"] / eval_every) * eval_every, env_steps)
        groups.setdefault(end, []).append(e)
    if not groups:
        raise InputError(f"{ev_path}: no evaluation episode")
    evals = ["total_steps,mean_return,std_return,mean_length,episodes,mean_cost"]
    final = math.nan
    for end in sorted(groups):
        g = groups[end]
        rets = [e["return"] for e in g]
        final = statistics.fmean(rets)
        mean_len = statistics.fmean(e["length"] for e in g)
        mean_cost = statistics.fmean(e["cost"] for e in g)
        evals.append(f"{end},{final!r},{statistics.pstdev(rets)!r},{mean_len!r},{len(g)},{mean_cost!r}")

    n = len(episodes)
    wall = float(run.get("wall_seconds") or 0.0)
    summary = {
        "env": run["env"],
        "algo": "sac",
        "seed": int(run["seed"]),
        "strategy": None,
        "mode": None,
        "acc_reward": final,
        "crash_pct": 100.0 * crashed / n if n else 0.0,
        "filtered_pct": 0.0,
        "episodes": n,
        "steps": env_steps,
        "filtered_steps": 0,
        "wall_seconds": wall,
        "steps_per_second": env_steps / wall if wall > 0 else 0.0,
        "complete": True,
        "crashes": crashed,
        "env_steps": env_steps,
        "crashes_per_1k_env_steps": 1000.0 * crashed / env_steps,
        "cost": total_cost,
        "cost_rate": total_cost / env_steps,
        "episode_cost_limit": float(run["cost_limit"]),
    }
    versions = run["versions"]
    config = "\n".join(
        [
            "# A peer's run, converted by tools/peers/omnisafe_run_dir.py from OmniSafe's own output in this",
            "# folder (episodes.csv, evals.csv, run.json): `defender report` reads it beside our runs;",
            "# `defender train` cannot resume or repeat it (tools/peers/omnisafe_saclag.py can).",
            f'env = "{run["env"]}"',
            'algo = "sac"',
            f"seed = {int(run['seed'])}",
            f"total_steps = {env_steps}",
            "total_episodes = 0",
            f"eval_freq = {eval_every}",
            "",
            "[peer]",
            f'name = "{PEER}"',
            'algo = "SACLag"',
            f'omnisafe = "{versions.get("omnisafe", "?")}"',
            f'safety_gymnasium = "{versions.get("safety-gymnasium", "?")}"',
            f'mujoco = "{versions.get("mujoco", "?")}"',
            f"cost_limit = {float(run['cost_limit'])!r}",
            f"steps_per_epoch = {int(run.get('steps_per_epoch') or 2000)}",
            "",
        ]
    )
    write_atomic(os.path.join(out, "metrics.csv"), "\n".join(metrics) + "\n")
    write_atomic(os.path.join(out, "eval.csv"), "\n".join(evals) + "\n")
    write_atomic(os.path.join(out, "config.toml"), config)
    write_json(os.path.join(out, "summary.json"), summary)
    return summary


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", help="an output folder of tools/peers/omnisafe_saclag.py")
    parser.add_argument(
        "--eval-every", type=int, default=10000, help="steps per eval.csv row (default 10000, as our runs)"
    )
    args = parser.parse_args()
    if args.eval_every <= 0:
        parser.error(f"--eval-every {args.eval_every}: must be positive")
    try:
        s = convert(args.out, args.eval_every)
    except InputError as e:
        print(f"omnisafe_run_dir: {e}", file=sys.stderr)
        return 2
    print(
        f"omnisafe_run_dir: {args.out}: {s['episodes']} episodes, {s['crashes']} fell, cost rate "
        f"{s['cost_rate']:.3f}, final evaluation {s['acc_reward']:.1f} -> config.toml, metrics.csv, "
        "eval.csv, summary.json"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
