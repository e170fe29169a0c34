#!/usr/bin/env python3
"""An episode set with only some of its observation features, for a diagnostic screen: does DTW
tell safe from unsafe episodes when it compares the features that carry the hazard, rather than
all of them? (docs/results-navigation.md, "Why".)

The navigation tasks' observation is the robot's sensors and three 16-bin lidars (goal, hazards,
vases; Safety-Gymnasium's `obs_space_dict` order). DEFENDER compares whole observations; this
writes a copy of a set whose observation is
  --columns A:B     the columns A..B-1 (e.g. the hazards lidar), or
  --max-of A:B      one feature: the largest of the columns A..B-1. For the hazards lidar (pseudo
                    lidar, 1 - distance / 3 per bin, clipped at 0) that is the nearness of the
                    closest hazard whatever its bearing; above 1 - 0.2 / 3 = 0.933 the robot is
                    inside one (hazard radius 0.2), the steps that cost.
Actions, rewards, lengths and labels are unchanged; `meta` keeps everything (the episode cost
limit among it) with the new obs_dim and a note of the selection. The columns come from
navigation_layout.py, which checks them against the task (`navigation_layout.py TASK
hazards_lidar` prints SafetyPointGoal1-v0's 28:44 of 60, SafetyCarGoal1-v0's 40:56 of 72).

  .deps/omnisafe-venv/bin/python tools/navigation/navigation_features.py \\
      --max-of "$(.deps/omnisafe-venv/bin/python tools/navigation/navigation_layout.py SafetyPointGoal1-v0 hazards_lidar)" \\
      --in results/navigation/SafetyPointGoal1-v0/demos.npz --out runs/point-demos-hazard.npz
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from defender_rl import EpisodeSet


def span(text: str) -> slice:
    try:
        a, b = (int(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give A:B, column A to B-1") from None
    if not 0 <= a < b:
        raise argparse.ArgumentTypeError(f"{text!r}: need 0 <= A < B")
    return slice(a, b)


def select(obs: np.ndarray, columns: slice | None, max_of: slice | None) -> np.ndarray:
    """The kept features of observations [T, d]."""
    cols = columns or max_of
    if cols.stop > obs.shape[1]:
        raise SystemExit(f"navigation_features: columns {cols.start}:{cols.stop} beyond obs_dim {obs.shape[1]}")
    part = obs[:, cols]
    return part.max(axis=1, keepdims=True) if max_of is not None else part


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--columns", type=span, help="keep columns A:B")
    which.add_argument("--max-of", type=span, help="one feature: the largest of columns A:B")
    parser.add_argument("--in", dest="src", required=True, help="an episode set (.npz)")
    parser.add_argument("--out", required=True, help="the copy (.npz)")
    args = parser.parse_args(argv)

    found = EpisodeSet.load(args.src)
    episodes = []
    for i in range(len(found)):
        e = found.episode(i)
        episodes.append((select(np.asarray(e["obs"], dtype=np.float64), args.columns, args.max_of),
                         e["act"], e["rew"], bool(e["crashed"])))
    meta = dict(found.meta)
    cols = args.columns or args.max_of
    how = "columns" if args.columns is not None else "the largest of columns"
    meta["features"] = f"{how} {cols.start}:{cols.stop} of obs_dim {meta.get('obs_dim')} (tools/navigation/navigation_features.py)"
    meta["obs_dim"] = int(episodes[0][0].shape[1])
    env_id = meta.pop("env_id", None)
    EpisodeSet.from_episodes(episodes, env_id=env_id, meta=meta).save(args.out)
    print(f"navigation_features: {len(episodes)} episodes, obs_dim {meta['obs_dim']} ({meta['features']}) -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
