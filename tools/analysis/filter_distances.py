#!/usr/bin/env python3
"""Why a strategy fires where it does: its Safe and Unsafe values (SPEC sections 3-4) at every step
of recorded episodes, and which demonstration decides each.

`defender screen` says whether the filter ends an episode and when; this says how close the
decision was and what drove it. For each recorded episode (`defender train --record-episodes`) and
each step t, the trajectory so far s_0..s_t is compared with the demonstrations the way a run
does (the strategy's windows and aggregations, state mode, optionally z-scored as
`[defender.cost] scaling = "zscore"`: fitted on every element of both groups). Written per step:

  episode, step, label        the recorded episode, t, and its label (unsafe / safe / neither:
                              SPEC section 13 on a cost task, section 6 on a crash task)
  safe, unsafe, ratio         Safe(tau), Unsafe(tau), Unsafe / Safe (the default profile filters
                              when ratio <= 1 - margin, margin 0.02)
  safe_demo, safe_len         the member that decided Safe under Min/Max (index within its group,
  unsafe_demo, unsafe_len     the file's demonstrations first, then own episodes; its length in
                              elements); -1 under Mean

With --per-episode, a second table: episode, label, steps (replayed: to the violating step for an
episode that passed the limit; not the rows --every writes), min_ratio and its
min_ratio_step, first_filtered_step (the first step whose ratio <= 1 - --margin, -1: none: where
a run with this margin would have ended the episode), and the lengths of the members that
decided Safe and Unsafe at most of its steps (safe_len, unsafe_len).

The groups are the file's demonstrations (SPEC's filter, `defender screen`'s `spec` variant) or,
with `--own-episodes K`, also the recorded episodes themselves as they end, the way the
keeps-learning profile lets a run's own episodes join (SPEC sections 11 and 13: an unsafe one
joins the unsafe group, one that reached the safe demonstrations' horizon the safe group, at most
K of each, the oldest replaced; scaled as the demonstrations, the scaling still fitted on them).
On a recording of a DEFENDER run this is what the run's filter saw (its margin aside: compare
`ratio` with 1 - margin). On a bare run's recording every unsafe episode joins, also those the
filter would have ended before their violation (`defender screen` models that, this does not). Needs the `defender_rl` package (`make python` installs it into .deps/venv):

  .deps/venv/bin/python tools/analysis/filter_distances.py --demos data/demos/SafetyHalfCheetahVelocity-v1.npz \\
      --episodes results/velocity/SafetyHalfCheetahVelocity-v1/sac-bare-s0/episodes.npz \\
      --strategy MinTrajW10/MaxTrajW10 --scaling zscore --every 5 --out distances.csv
"""

from __future__ import annotations

import argparse
import collections
import csv
import math
import os
import sys
import tempfile

import numpy as np

import defender_rl

AGGREGATIONS = ("Min", "Max", "Mean")


def episodes(path: str) -> tuple[list[np.ndarray], np.ndarray]:
    """The state sequences [o_0..o_N] of a file's episodes and their labels, read (and checked,
    with errors naming the file and array) by the package's own loader."""
    found = defender_rl.EpisodeSet.load(path)
    eps = [found.episode(i) for i in range(len(found))]
    return [np.asarray(e["obs"], dtype=np.float64) for e in eps], np.array([bool(e["crashed"]) for e in eps])


def split_method(method: str) -> tuple[str, str]:
    for agg in AGGREGATIONS:
        if method.startswith(agg):
            return agg, method[len(agg) :]
    raise SystemExit(f"--strategy: {method!r} does not start with one of {AGGREGATIONS}")


def decider(agg: str, costs: list[float]) -> int:
    if agg == "Min":
        return int(np.argmin(costs))
    if agg == "Max":
        return int(np.argmax(costs))
    return -1


PER_EPISODE = ["episode", "label", "steps", "min_ratio", "min_ratio_step", "first_filtered_step",
               "safe_len", "unsafe_len"]


def summary(rows: list[tuple], margin: float) -> list:
    """One episode's row of --per-episode: its smallest ratio and where, the first step the
    filter would end it at this margin (-1: none), and the lengths of the members that decided
    Safe and Unsafe most often."""
    ratios = [r[5] for r in rows]
    k = int(np.argmin(ratios))
    fired = [r[1] for r in rows if r[5] <= 1.0 - margin]
    common = lambda col: collections.Counter(r[col] for r in rows).most_common(1)[0][0]  # noqa: E731
    # steps: the steps replayed (the last t + 1), not the rows written, which --every thins.
    return [rows[0][0], rows[0][2], rows[-1][1] + 1, f"{ratios[k]:.4f}", rows[k][1], fired[0] if fired else -1,
            common(7), common(9)]


def write_csv(path: str, header: list[str], rows) -> None:
    """Atomically: a temporary file beside `path`, renamed over it when complete."""
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), prefix=".filter_distances.")
    try:
        with os.fdopen(fd, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            w.writerows(rows)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's file is private; the table is not
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--demos", required=True, help="the demonstration set (.npz)")
    p.add_argument("--episodes", required=True, help="recorded episodes (.npz) to replay")
    p.add_argument("--strategy", required=True, help="SAFE/UNSAFE, e.g. MinTrajW10/MaxTrajW10")
    p.add_argument("--scaling", choices=("none", "zscore"), default="none", help="feature scaling (default: none)")
    p.add_argument("--every", type=int, default=1, help="every k-th step, and each episode's last (default: 1)")
    p.add_argument("--first", type=int, help="only the first N recorded episodes")
    p.add_argument("--own-episodes", type=int, default=0, metavar="K",
                   help="let the recorded episodes join the groups as they end, at most K per group (default: 0)")
    p.add_argument("--margin", type=float, default=0.02,
                   help="for --per-episode: the filter fires when ratio <= 1 - margin (default: 0.02, the default profile's)")
    p.add_argument("--out", required=True, help="the per-step table (CSV), written atomically")
    p.add_argument("--per-episode", metavar="CSV", help="also a table with one row per episode (see above)")
    a = p.parse_args()
    if a.every < 1:
        p.error("--every must be >= 1")
    if a.own_episodes < 0:
        p.error("--own-episodes must be >= 0")
    if not 0.0 <= a.margin < 1.0:
        p.error("--margin must be in [0, 1)")
    if "/" not in a.strategy:
        p.error(f"--strategy {a.strategy!r}: expected SAFE/UNSAFE")
    (safe_agg, _), (unsafe_agg, _) = (split_method(m) for m in a.strategy.split("/"))
    safe_method, unsafe_method = a.strategy.split("/")

    demos, crashed = episodes(a.demos)
    recorded, rec_crashed = episodes(a.episodes)
    if demos[0].shape[1] != recorded[0].shape[1]:
        raise SystemExit(f"--episodes: observation dimension {recorded[0].shape[1]}, --demos: {demos[0].shape[1]}")
    if a.scaling == "zscore":
        rows = np.concatenate(demos)
        mean, std = rows.mean(axis=0), rows.std(axis=0)
        std[std < 1e-6] = 1.0
        scale = lambda x: ((x - mean) / std).astype(np.float32)  # noqa: E731
    else:
        scale = lambda x: x.astype(np.float32)  # noqa: E731
    safe = [scale(d) for d, c in zip(demos, crashed) if not c]
    unsafe = [scale(d) for d, c in zip(demos, crashed) if c]
    horizon = max(len(d) for d in safe)  # elements of a whole safe episode (N + 1)
    own_safe: list[np.ndarray] = []
    own_unsafe: list[np.ndarray] = []
    n = len(recorded) if a.first is None else min(a.first, len(recorded))

    header = ["episode", "step", "label", "safe", "unsafe", "ratio", "safe_demo", "safe_len", "unsafe_demo", "unsafe_len"]
    steps, per_episode = [], []
    for e in range(n):
        x = scale(recorded[e])
        last = len(x) - 2  # the last step's state s_t: o_{N-1} (o_N follows the last action)
        label = "unsafe" if rec_crashed[e] else ("safe" if len(x) >= horizon else "neither")
        safe_group, unsafe_group = safe + own_safe, unsafe + own_unsafe
        mine = []
        for t in sorted(set(range(0, last + 1, a.every)) | {last}):
            s, s_costs = defender_rl.group_cost(x[: t + 1], safe_group, safe_method)
            u, u_costs = defender_rl.group_cost(x[: t + 1], unsafe_group, unsafe_method)
            i, j = decider(safe_agg, s_costs), decider(unsafe_agg, u_costs)
            mine.append((e, t, label, s, u, u / s if s > 0 else math.inf,
                         i, len(safe_group[i]) if i >= 0 else -1, j, len(unsafe_group[j]) if j >= 0 else -1))
        steps += mine
        per_episode.append(summary(mine, a.margin))
        if a.own_episodes and label != "neither":
            joined = own_unsafe if label == "unsafe" else own_safe
            joined.append(x)
            del joined[: max(0, len(joined) - a.own_episodes)]
        print(f"\repisode {e + 1}/{n}", end="", file=sys.stderr, flush=True)
    write_csv(a.out, header, ([*r[:3], f"{r[3]:.6g}", f"{r[4]:.6g}", f"{r[5]:.6g}", *r[6:]] for r in steps))
    if a.per_episode:
        write_csv(a.per_episode, PER_EPISODE, per_episode)
        print(f"\nwrote {a.per_episode}", end="", file=sys.stderr)
    print(f"\nwrote {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
