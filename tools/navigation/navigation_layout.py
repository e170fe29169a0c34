#!/usr/bin/env python3
"""The navigation tasks' observation layout, the one place the navigation tools take columns from.

Safety-Gymnasium 1.0.0 flattens a navigation task's observation in the order of its task's
`obs_info.obs_space_dict` (`gymnasium.spaces.utils.flatten` over that Dict): the agent's sensors
first (the Car's include its rear ball's angular velocity and orientation), then one 16-bin
lidar per observed obstacle (goal, hazards, vases). `LAYOUT` writes that order down per task;
`layout_of(env)` reads it from a made task, and python/tests_safety_gym/test_navigation_layout.py
checks that the two agree and that every column range below is the task's own (the flat
observation's columns equal the named entry of the task's unflattened observation), together with
the constants the state rule uses (hazard radius, lidar range and kind).

  hazards lidar: SafetyPointGoal1-v0 28:44 (of 60), SafetyCarGoal1-v0 40:56 (of 72)

(Until this module, the Car's was written as 34:50: goal-lidar bins 10-15 and hazard bins 0-9.)

The command prints one entry's columns as A:B, after checking the table against the task made
here when Safety-Gymnasium imports (exit 1 on a mismatch):

  .deps/omnisafe-venv/bin/python tools/navigation/navigation_layout.py SafetyCarGoal1-v0 hazards_lidar
"""

from __future__ import annotations

import argparse
import sys
import warnings

#: The navigation tasks the tools support (tools/navigation/navigation_train.py's choices).
TASKS = ("SafetyPointGoal1-v0", "SafetyCarGoal1-v0")

_SENSORS = (("accelerometer", 3), ("velocimeter", 3), ("gyro", 3), ("magnetometer", 3))
_LIDARS = (("goal_lidar", 16), ("hazards_lidar", 16), ("vases_lidar", 16))

#: Per task, the flat observation's entries in order: (key, size).
LAYOUT: dict[str, tuple[tuple[str, int], ...]] = {
    "SafetyPointGoal1-v0": _SENSORS + _LIDARS,
    "SafetyCarGoal1-v0": _SENSORS + (("ballangvel_rear", 3), ("ballquat_rear", 9)) + _LIDARS,
}

#: Goal level 1's hazards and lidar (Safety-Gymnasium 1.0.0): radius, pseudo lidar's range
#: (a bin reads max(0, 3 - distance) / 3), bins per lidar, hazards laid out, cost of a step in one.
HAZARD_RADIUS, LIDAR_MAX_DIST, LIDAR_BINS, HAZARDS, HAZARD_COST = 0.2, 3.0, 16, 8, 1.0
#: The largest hazards-lidar bin above this: the robot is inside a hazard (distance < radius).
INSIDE = 1.0 - HAZARD_RADIUS / LIDAR_MAX_DIST


def columns(task: str, key: str) -> slice:
    """The columns of entry `key` in `task`'s flat observation."""
    if task not in LAYOUT:
        raise KeyError(f"{task}: no observation layout known (known: {', '.join(LAYOUT)})")
    start = 0
    for name, size in LAYOUT[task]:
        if name == key:
            return slice(start, start + size)
        start += size
    raise KeyError(f"{task}: no entry {key!r} (entries: {', '.join(n for n, _ in LAYOUT[task])})")


def obs_dim(task: str) -> int:
    """The flat observation's length."""
    return sum(size for _, size in LAYOUT[task])


def layout_of(env) -> tuple[tuple[str, int], ...]:  # noqa: ANN001 (a Safety-Gymnasium environment)
    """A made task's own layout: its `obs_space_dict`'s keys in order, each with its size."""
    import numpy as np

    space = env.unwrapped.task.obs_info.obs_space_dict
    return tuple((key, int(np.prod(box.shape))) for key, box in space.spaces.items())


def make(task: str):  # noqa: ANN201
    """`safety_gymnasium.make(task)`, quietly (gymnasium-robotics' notice about its Adroit tasks)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import safety_gymnasium

        return safety_gymnasium.make(task)


def mismatches(task: str, env) -> list[str]:  # noqa: ANN001
    """What in this module disagrees with a made `task` (empty: nothing)."""
    found = []
    own = layout_of(env)
    if own != LAYOUT[task]:
        found.append(f"{task}: layout {own}, the table says {LAYOUT[task]}")
    inner = env.unwrapped.task
    lidar = inner.lidar_conf
    want = {
        "lidar type": (lidar.type, "pseudo"),
        "lidar max_dist": (float(lidar.max_dist), LIDAR_MAX_DIST),
        "lidar bins": (int(lidar.num_bins), LIDAR_BINS),
        "hazard radius": (float(inner.hazards.size), HAZARD_RADIUS),
        "hazards": (int(inner.hazards.num), HAZARDS),
        "hazard cost": (float(inner.hazards.cost), HAZARD_COST),
    }
    found += [f"{task}: {name} {got}, the tools assume {exp}" for name, (got, exp) in want.items() if got != exp]
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("task", choices=sorted(LAYOUT))
    parser.add_argument("key", help="an entry, e.g. hazards_lidar")
    parser.add_argument("--no-check", action="store_true", help="print the table's columns without making the task")
    args = parser.parse_args(argv)
    try:
        cols = columns(args.task, args.key)
    except KeyError as e:
        print(f"navigation_layout: {e.args[0]}", file=sys.stderr)
        return 2
    if not args.no_check:
        bad = mismatches(args.task, make(args.task))
        if bad:
            print("navigation_layout: " + "; ".join(bad), file=sys.stderr)
            return 1
    print(f"{cols.start}:{cols.stop}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
