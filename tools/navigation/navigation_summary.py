#!/usr/bin/env python3
"""The figures docs/results-navigation.md quotes beside the screens, from one task's folder of
tools/navigation/navigation-screen.sh, into a JSON file (and printed):

  learner       per seed: episodes safe / unsafe, and per epoch the safe count, mean episode
                cost and mean return (labels.csv); the cost rate (cost / steps)
  hazard_stays  per seed: over unsafe episodes, the steps from the first step that cost to the
                step that passed the limit (quartiles, min); safe episodes that paid any cost.
                On these tasks a step costs 1 while the robot is inside a hazard (Goal level 1:
                8 hazards of radius 0.2, cost 1 each; the vase costs nothing)
  inside_rule   a state rule, not DEFENDER, on seed 1's recorded episodes (the screen's): "the
                closest hazard is nearer than its radius", the largest hazards-lidar bin above
                1 - 0.2 / 3 (pseudo lidar: 1 - distance / 3; the columns: navigation_layout.py),
                replayed as the screen replays a filter. A step costs when it ends inside a
                hazard, so the rule fires on the step after a cost: it reads the cost signal one
                step late. Reported: caught % (unsafe episodes where it fires before the
                violating step), false alarm % (safe episodes where it fires), mean lead (steps
                from firing to the violating step). It says whether the observation holds what separates the
                groups, and when
  demonstrations  candidates by label (demo-candidates.csv); the kept set's unsafe lengths
  selection, screen, features/*   auto's choice (its leave-one-out figures) and the screens'
                rows, as the CLI wrote them
  classifier    navigation_classifier.py's classifier.json (its choice, its cross-validation on
                the demonstrations, its held-out figures), when present

  .deps/omnisafe-venv/bin/python tools/navigation/navigation_summary.py --task-dir results/navigation/SafetyPointGoal1-v0 \\
      --out results/navigation/SafetyPointGoal1-v0/summary.json
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import sys

import numpy as np

from defender_rl import EpisodeSet

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# Goal level 1's hazards and lidar, and the columns: navigation_layout.py (checked against the task).
from navigation_layout import INSIDE, LAYOUT, columns  # noqa: E402,F401


def read(path: str) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def quartiles(xs: list[float]) -> list[float] | None:
    if len(xs) < 2:
        return None
    return [round(q, 2) for q in statistics.quantiles(xs, n=4)]


def learner(run: str) -> dict:
    rows = read(os.path.join(run, "labels.csv"))
    with open(os.path.join(run, "run.json"), encoding="utf-8") as f:
        meta = json.load(f)
    per_epoch = meta["steps_per_epoch"] // 1000  # 1,000-step episodes
    epochs = []
    for e in range(0, len(rows), per_epoch):
        part = rows[e : e + per_epoch]
        epochs.append({
            "epoch": e // per_epoch,
            "safe": sum(r["label"] == "safe" for r in part),
            "unsafe": sum(r["label"] == "unsafe" for r in part),
            "mean_cost": round(statistics.fmean(float(r["cost"]) for r in part), 2),
            "mean_return": round(statistics.fmean(float(r["return"]) for r in part), 3),
        })
    unsafe = [r for r in rows if r["label"] == "unsafe"]
    safe = [r for r in rows if r["label"] == "safe"]
    stays = [int(r["recorded_steps"]) - int(r["first_cost_step"]) for r in unsafe]
    steps = sum(int(r["length"]) for r in rows)
    return {
        "labels": meta["labels"],
        "steps": steps,
        "cost_rate": round(sum(float(r["cost"]) for r in rows) / steps, 4),
        "epochs": epochs,
        "hazard_stays": {
            "unsafe_first_cost_to_violation_quartiles": quartiles(stays),
            "unsafe_first_cost_to_violation_min": min(stays) if stays else None,
            "unsafe_first_cost_step_quartiles": quartiles([int(r["first_cost_step"]) for r in unsafe]),
            "safe_with_any_cost": sum(float(r["cost"]) > 0 for r in safe),
            "safe": len(safe),
        },
    }


def inside_rule(path: str, hazards: slice) -> dict:
    """The state rule replayed on a recorded set (see the module's docstring)."""
    found = EpisodeSet.load(path)
    caught = alarms = unsafe = safe = 0
    leads = []
    for i in range(len(found)):
        e = found.episode(i)
        n = len(e["rew"])
        near = np.asarray(e["obs"])[:n, hazards].max(axis=1)  # s_0..s_{n-1}: the decided steps
        fired = np.flatnonzero(near > INSIDE)
        if e["crashed"]:
            unsafe += 1
            if fired.size:
                caught += 1
                leads.append(n - int(fired[0]))
        else:
            safe += 1
            alarms += int(fired.size > 0)
    return {
        "threshold": round(INSIDE, 4),
        "unsafe": unsafe,
        "safe": safe,
        "caught_pct": round(100 * caught / unsafe, 1) if unsafe else None,
        "false_alarm_pct": round(100 * alarms / safe, 1) if safe else None,
        "mean_lead": round(statistics.fmean(leads), 1) if leads else None,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task-dir", required=True, help="results/navigation/<task>")
    parser.add_argument("--hazards", help="the hazards lidar's columns A:B (default: navigation_layout.py's for "
                        "the folder's task; given, they must agree)")
    parser.add_argument("--out", required=True, help="the summary (.json)")
    args = parser.parse_args(argv)
    d = args.task_dir
    task = os.path.basename(os.path.normpath(d))
    if args.hazards is not None:
        a, b = (int(x) for x in args.hazards.split(":"))
        hazards = slice(a, b)
        if task in LAYOUT and hazards != columns(task, "hazards_lidar"):
            known = columns(task, "hazards_lidar")
            parser.error(f"--hazards {a}:{b}: {task}'s hazards lidar is {known.start}:{known.stop} (navigation_layout.py)")
    elif task in LAYOUT:
        hazards = columns(task, "hazards_lidar")
    else:
        parser.error(f"{task}: no layout known; give --hazards")

    out: dict = {"task": task, "hazards_columns": f"{hazards.start}:{hazards.stop}"}
    out["learner"] = {f"seed{s}": learner(os.path.join(d, f"ppolag-s{s}")) for s in (0, 1)}
    out["inside_rule_seed1"] = inside_rule(os.path.join(d, "ppolag-s1", "episodes.npz"), hazards)
    cands = read(os.path.join(d, "demo-candidates.csv"))
    demos = EpisodeSet.load(os.path.join(d, "demos.npz"))
    lengths = [len(demos.episode(i)["rew"]) for i in range(len(demos)) if demos.episode(i)["crashed"]]
    out["demonstrations"] = {
        "candidates": {k: sum(r["label"] == k for r in cands) for k in ("safe", "unsafe", "neither")},
        "kept": dict(zip(("safe", "unsafe"), demos.group_sizes)),
        "unsafe_length_quartiles": quartiles(lengths),
    }
    out["selection"] = read(os.path.join(d, "selection.csv"))[0]
    out["screen"] = read(os.path.join(d, "screen.csv"))
    for kind in ("hlidar", "hmax"):
        f = os.path.join(d, "features")
        if os.path.exists(os.path.join(f, f"{kind}-screen.csv")):
            out[f"features_{kind}"] = {
                "selection": read(os.path.join(f, f"{kind}-selection.csv"))[0],
                "screen": read(os.path.join(f, f"{kind}-screen.csv")),
            }
    if os.path.exists(os.path.join(d, "classifier.json")):
        with open(os.path.join(d, "classifier.json"), encoding="utf-8") as f:
            found = json.load(f)
        out["classifier"] = {
            "chosen": found["chosen"],
            "cross_validation": found["cross_validation"],
            "heldout": found["heldout"],
        }
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print(json.dumps({k: out[k] for k in ("task", "inside_rule_seed1", "demonstrations")}, indent=1))
    for s in (0, 1):
        lr = out["learner"][f"seed{s}"]
        print(f"seed {s}: {lr['labels']}, cost rate {lr['cost_rate']}, stays {lr['hazard_stays']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
