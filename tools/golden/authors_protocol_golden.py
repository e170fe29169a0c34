#!/usr/bin/env python3
"""Golden values of the authors' offline ablation and of their choice of demonstrations for
diversity (docs/SPEC.md section 10), computed independently of the Rust code: numpy and the PyPI
`fastdtw` package 0.3.4 (its pure-Python module, as tools/golden/fastdtw_golden.py uses it), following
the facts of their `util/ablations/dtw_extract.py`, `dtw_process.py` and
`util/demonstration.py` as docs/SPEC.md states them (this is not their code).

Writes crates/defender/tests/data/authors_protocol/:

  demos.npz        4 safe demonstrations (25 steps, the horizon) and 4 unsafe ones (11-16 steps);
                   each unsafe one ends with the last 10 elements of a safe one, so that strategies
                   with the same aggregation and a window of 5 or 10 demonstration steps tie exactly
                   (their ties execute)
  episodes.npz     40 recorded episodes of 1-25 steps; `crashed` is set against the length for some
                   of them (the authors' score tests the length only)
  scores-<case>.csv  mode,strategy,mean_ratio,safe_rate,score for the 576 strategies, <case> one of
                   state (all demonstrations), state-action (all), state-diverse3 (3 per group chosen
                   for diversity)
  diverse.txt      per mode and group, every demonstration in farthest-point order

The horizon is 25. Costs: fastdtw(demonstration part, trajectory part) with radius 1 and the L1
distance, the trajectory capped to its last 20 elements, one element per transition; a step is
filtered when safe - unsafe > 0; p = k / T; the score is mean(p) * mean(avoided over episodes
shorter than the horizon). The script checks that no decision is a near tie (|safe - unsafe|
below 2e-7 of their size, 3 units of f32 rounding, without being exactly 0), so that costs
rounded to f32 (as the Rust filter keeps them) cannot flip one.

Run: .deps/tools-venv/bin/python tools/golden/authors_protocol_golden.py   (numpy, fastdtw 0.3.4)
"""

import json
from pathlib import Path

import fastdtw
import numpy as np

OUT = Path(__file__).resolve().parents[2] / "crates/defender/tests/data/authors_protocol"
HORIZON = 25
CAP = 20
OBS, ACT = 3, 2
WINDOWS = ["Both", "Equal", "TrajW5", "TrajW10", "DemoW5", "DemoW10", "BothW5", "BothW10"]
AGGS = {"Min": np.min, "Max": np.max, "Mean": np.mean}
METHODS = [a + w for a in AGGS for w in WINDOWS]
NEAR = []


def cost(demo, traj):
    return float(fastdtw.fastdtw(demo, traj, radius=1, dist=None)[0])


def windowed(window, traj, demo):
    """(demonstration part, trajectory part) of a window (SPEC section 3)."""
    n = len(traj)
    return {
        "Both": (demo, traj),
        "Equal": (demo[-n:], traj),
        "TrajW5": (demo, traj[-5:]),
        "TrajW10": (demo, traj[-10:]),
        "DemoW5": (demo[-5:], traj),
        "DemoW10": (demo[-10:], traj),
        "BothW5": (demo[-5:], traj[-5:]),
        "BothW10": (demo[-10:], traj[-10:]),
    }[window]


def method_values(traj, demos):
    """The 24 methods' values of one group for the capped trajectory."""
    out = {}
    for w in WINDOWS:
        costs = [cost(*windowed(w, traj, d)) for d in demos]
        for a, f in AGGS.items():
            out[a + w] = float(f(costs))
    return out


def walk(rng, n, dim, scale=1.0):
    return (np.cumsum(rng.normal(size=(n, dim)), axis=0) * scale).astype(np.float32)


def episode(rng, steps):
    obs = walk(rng, steps + 1, OBS)
    act = rng.uniform(-1, 1, size=(steps, ACT)).astype(np.float32)
    rew = rng.normal(size=steps).astype(np.float32)
    return obs, act, rew


def save(path, episodes, meta):
    obs = np.concatenate([e[0] for e in episodes]).astype(np.float32)
    act = np.concatenate([e[1] for e in episodes]).astype(np.float32)
    rew = np.concatenate([e[2] for e in episodes]).astype(np.float32)
    ep_len = np.array([len(e[2]) for e in episodes], dtype=np.int64)
    crashed = np.array([e[3] for e in episodes], dtype=bool)
    meta = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    np.savez(path, obs=obs, act=act, rew=rew, ep_len=ep_len, crashed=crashed, meta=meta)


def sequence(e, mode):
    """One element per transition: o_t, or concat(o_t, a_t)."""
    obs, act = e[0], e[1]
    steps = len(e[2])
    if mode == "state":
        return obs[:steps]
    return np.concatenate([obs[:steps], act], axis=1)


def farthest_point(seqs):
    """Every item in farthest-point order: the most distant pair (first in row-major order on
    ties), then the largest mean cost to those chosen (lowest index on ties)."""
    n = len(seqs)
    c = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            c[i, j] = c[j, i] = cost(seqs[i], seqs[j])
    best = max(((c[i, j], -i, -j) for i in range(n) for j in range(i + 1, n)))
    chosen = [-best[1], -best[2]]
    while len(chosen) < n:
        rest = [k for k in range(n) if k not in chosen]
        means = [np.mean([c[k, s] for s in chosen]) for k in rest]
        chosen.append(rest[int(np.argmax(means))])
    return chosen


def scores(safe, unsafe, episodes, mode):
    first = {(s, u): [] for s in METHODS for u in METHODS}
    for e in episodes:
        seq = sequence(e, mode)
        open_ = set(first)
        ks = {key: None for key in first}
        for t in range(len(seq)):
            traj = seq[: t + 1][-CAP:]
            sv = method_values(traj, safe)
            uv = method_values(traj, unsafe)
            for key in list(open_):
                diff = sv[key[0]] - uv[key[1]]
                scale = max(abs(sv[key[0]]), abs(uv[key[1]]), 1e-12)
                if diff != 0 and abs(diff) < 2e-7 * scale:
                    NEAR.append((mode, key, t, diff))
                if diff > 0:
                    ks[key] = t
                    open_.discard(key)
            if not open_:
                break
        for key in first:
            first[key].append((len(seq), ks[key]))
    rows = []
    for (s, u), runs in first.items():
        p = [1.0 if k is None else k / n for n, k in runs]
        crashed = [k is not None for n, k in runs if n < HORIZON]
        avoided = float(np.mean(crashed)) if crashed else 1.0
        rows.append((mode, f"{s}/{u}", float(np.mean(p)), avoided, float(np.mean(p)) * avoided))
    return rows


def write_scores(name, rows):
    with open(OUT / f"scores-{name}.csv", "w") as f:
        f.write("mode,strategy,mean_ratio,safe_rate,score\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]},{r[2]!r},{r[3]!r},{r[4]!r}\n")


def main():
    if fastdtw.fastdtw.__module__ != "fastdtw.fastdtw":
        raise SystemExit(f"expected the pure-Python fastdtw module, got {fastdtw.fastdtw.__module__}")
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20240624)
    safe = [episode(rng, HORIZON) + (False,) for _ in range(4)]
    unsafe = []
    for k, steps in enumerate((11, 12, 14, 16)):
        obs, act, rew = episode(rng, steps)
        # The last 10 elements (observations before each action, and the actions) of safe k.
        obs[steps - 10 : steps] = safe[k][0][HORIZON - 10 : HORIZON]
        act[steps - 10 :] = safe[k][1][HORIZON - 10 :]
        unsafe.append((obs, act, rew, True))
    # File order interleaves the groups; each group keeps its own order.
    demos = [safe[0], unsafe[0], unsafe[1], safe[1], safe[2], unsafe[2], safe[3], unsafe[3]]
    save(OUT / "demos.npz", demos, {"env_id": "Golden-v0", "provenance": "tools/golden/authors_protocol_golden.py"})

    episodes = []
    for i in range(40):
        steps = HORIZON if i % 5 == 0 else int(rng.integers(1, HORIZON))
        obs, act, rew = episode(rng, steps)
        # Near the demonstrations, sometimes: start from one of them.
        if i % 3 == 0:
            src = demos[i % len(demos)]
            m = min(steps, len(src[2]))
            obs[:m] = src[0][:m] + rng.normal(scale=0.05, size=(m, OBS)).astype(np.float32)
        # The recorded flag disagrees with the length for every seventh episode.
        crashed = (steps < HORIZON) != (i % 7 == 3)
        episodes.append((obs, act, rew, crashed))
    save(OUT / "episodes.npz", episodes, {"env_id": "Golden-v0", "provenance": "tools/golden/authors_protocol_golden.py"})

    lines = []
    for mode in ("state", "state-action"):
        for group, members in (("safe", safe), ("unsafe", unsafe)):
            order = farthest_point([sequence(e, mode) for e in members])
            lines.append(f"{mode} {group} " + " ".join(map(str, order)))
    (OUT / "diverse.txt").write_text("\n".join(lines) + "\n")

    seq_of = lambda group, mode: [sequence(e, mode) for e in group]
    write_scores("state", scores(seq_of(safe, "state"), seq_of(unsafe, "state"), episodes, "state"))
    write_scores(
        "state-action",
        scores(seq_of(safe, "state-action"), seq_of(unsafe, "state-action"), episodes, "state-action"),
    )
    pick = lambda group: [group[k] for k in farthest_point(seq_of(group, "state"))[:3]]
    write_scores("state-diverse3", scores(seq_of(pick(safe), "state"), seq_of(pick(unsafe), "state"), episodes, "state"))
    if NEAR:
        raise SystemExit(f"near ties (change the seed): {NEAR[:5]}")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
