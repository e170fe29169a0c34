#!/usr/bin/env python3
"""The `classifier` trigger (docs/SPEC.md section 15) in the navigation tasks' offline screen:
trained on the demonstrations the DTW screen uses, replayed on the same held-out episodes (seed
1's recorded training episodes) and measured as the screen measures DTW and the state rule
(docs/results-navigation.md).

The classifier is SPEC's, in numpy (crates/defender/src/classifier.rs is the reference): a
network of two hidden layers of 64 (ReLU) over the last 5 states (the first repeated before an
episode has 5), each z-scored by the demonstrations' column statistics (a constant column: 1);
PyTorch's default initialisation; binary cross-entropy, Adam (lr 1e-3), batches of 256 half
unsafe, half safe; step t of an episode of N decisions is unsafe when the episode is unsafe and
N - t <= H, every other step safe; 3,000 gradient steps on the demonstrations. On a replayed
episode it ends the episode at the first step t whose probability is > threshold.

Two variants, as the DTW screen's columns: `demos` (the demonstrations only: SPEC's filter) and
`own50` (the default's treatment, as decisions-triggers.md gives the classifier: an episode it
did not end joins its group, a crash the unsafe data and an episode that reached the horizon the
safe data, at most 50 per group, the oldest replaced, then 50 gradient steps; an ended one never).

Measures, over the held-out episodes (as `defender screen` and the state rule count them): caught
% (unsafe episodes ended at a step t < N, before the violating step N - 1 runs), false alarms %
(safe episodes ended), mean lead (N - t over the caught ones).

**The choice of (H, threshold), written before it ran**: H in {10, 30}, threshold in {0.5, 0.9}.
On the training split only: 5-fold cross-validation on the demonstrations (folds: every 5th safe
and every 5th unsafe demonstration), each fold replayed through a `demos` classifier trained on
the other four; the setting with the highest caught % among those with at most 10% false alarms
(ties: fewer false alarms, then the smaller H, then the higher threshold); if none has, the
fewest false alarms. That setting is applied once to the held-out episodes; the other settings'
held-out figures are written beside it and do not enter the choice. Every figure is the mean over
--seeds classifier seeds (initialisation and batches), with their range.

Into --out (JSON) and --csv (one row per split, variant, H, threshold and seed).

  .deps/omnisafe-venv/bin/python tools/navigation/navigation_classifier.py \\
      --demos results/navigation/SafetyCarGoal1-v0/demos.npz \\
      --episodes results/navigation/SafetyCarGoal1-v0/ppolag-s1/episodes.npz \\
      --out results/navigation/SafetyCarGoal1-v0/classifier.json --csv results/navigation/SafetyCarGoal1-v0/classifier.csv
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from collections import deque

import numpy as np

HIDDEN, BATCH, LR, WINDOW, PRETRAIN, KEEP, UPDATE = 64, 256, 1e-3, 5, 3000, 50, 50
HORIZONS, THRESHOLDS, FOLDS, MAX_FALSE_ALARMS = (10, 30), (0.5, 0.9), 5, 10.0


def load(path: str) -> list[tuple[np.ndarray, bool]]:
    """An episode set (docs/SPEC.md section 8) as (states s_0..s_{N-1} [N, d], unsafe) per
    episode: the states the filter decides on (the last observation is never decided on)."""
    with np.load(path) as z:
        obs, lens, crashed = z["obs"].astype(np.float64), z["ep_len"], z["crashed"]
    out, start = [], 0
    for n, c in zip(lens.tolist(), crashed.tolist()):
        out.append((obs[start : start + n], bool(c)))
        start += n + 1
    if start != len(obs):
        raise SystemExit(f"navigation_classifier: {path}: obs has {len(obs)} rows, ep_len adds up to {start}")
    return out


def labels(n: int, unsafe: bool, horizon: int) -> np.ndarray:
    """Step t is unsafe when the episode is and its failure is at most `horizon` steps ahead."""
    t = np.arange(n)
    return (unsafe & (n - t <= horizon)).astype(np.float32)


def windows(states: np.ndarray) -> np.ndarray:
    """[N, WINDOW * d]: row t holds s_{t-4}..s_t, the first state repeated before step 4."""
    n = len(states)
    idx = np.maximum(np.arange(n)[:, None] + np.arange(WINDOW)[None, :] - (WINDOW - 1), 0)
    return states[idx].reshape(n, -1)


class Net:
    """[in, 64, 64, 1], ReLU, PyTorch's default initialisation, Adam; float32."""

    def __init__(self, inputs: int, rng: np.random.Generator) -> None:
        self.params = []
        for fan_in, fan_out in ((inputs, HIDDEN), (HIDDEN, HIDDEN), (HIDDEN, 1)):
            bound = 1.0 / np.sqrt(fan_in)
            self.params.append(rng.uniform(-bound, bound, (fan_in, fan_out)).astype(np.float32))
            self.params.append(rng.uniform(-bound, bound, fan_out).astype(np.float32))
        self.m = [np.zeros_like(p) for p in self.params]
        self.v = [np.zeros_like(p) for p in self.params]
        self.t = 0

    def logits(self, x: np.ndarray) -> np.ndarray:
        w1, b1, w2, b2, w3, b3 = self.params
        h1 = np.maximum(x @ w1 + b1, 0)
        h2 = np.maximum(h1 @ w2 + b2, 0)
        return (h2 @ w3 + b3)[:, 0]

    def loss(self, x: np.ndarray, y: np.ndarray) -> float:
        """The mean binary cross-entropy of logits(x) against labels y."""
        z = self.logits(x).astype(np.float64)
        return float(np.mean(np.logaddexp(0.0, z) - y * z))

    def gradients(self, x: np.ndarray, y: np.ndarray) -> list[np.ndarray]:
        """The loss's gradient with respect to each parameter (backpropagation by hand)."""
        w1, b1, w2, b2, w3, b3 = self.params
        a1 = x @ w1 + b1
        h1 = np.maximum(a1, 0)
        a2 = h1 @ w2 + b2
        h2 = np.maximum(a2, 0)
        z = (h2 @ w3 + b3)[:, 0]
        with np.errstate(over="ignore"):  # exp(-z) = inf for a very negative z: the sigmoid's 0
            g = ((1.0 / (1.0 + np.exp(-z)) - y) / len(y)).astype(w3.dtype)[:, None]
        d2 = (g @ w3.T) * (a2 > 0)
        d1 = (d2 @ w2.T) * (a1 > 0)
        return [x.T @ d1, d1.sum(0), h1.T @ d2, d2.sum(0), h2.T @ g, g.sum(0)]

    def step(self, x: np.ndarray, y: np.ndarray) -> None:
        """One Adam step (beta 0.9, 0.999, eps 1e-8) on the loss."""
        self.t += 1
        b1c, b2c = 1 - 0.9**self.t, 1 - 0.999**self.t
        for p, grad, m, v in zip(self.params, self.gradients(x, y), self.m, self.v):
            m *= 0.9
            m += 0.1 * grad
            v *= 0.999
            v += 0.001 * grad * grad
            p -= (LR * (m / b1c) / (np.sqrt(v / b2c) + 1e-8)).astype(p.dtype)


class Classifier:
    """SPEC section 15's classifier over `demos` with horizon `horizon`; `keep`: own episodes per
    group (None: the demonstrations only)."""

    def __init__(self, demos: list, horizon: int, seed: int, keep: int | None = None) -> None:
        states = np.concatenate([s for s, _ in demos])
        mean, var = states.mean(0), states.var(0)
        self.mean = mean
        self.inv_std = np.where(var > 1e-12, 1.0 / np.sqrt(np.maximum(var, 1e-300)), 1.0)
        self.horizon, self.keep = horizon, keep
        self.rng = np.random.default_rng(seed)
        self.demos = [self._labelled(s, u) for s, u in demos]
        self.own: list[deque] = [deque(), deque()]
        self.net = Net(self.demos[0][0].shape[1], self.rng)
        self._index()
        if not len(self.index[1]):
            raise SystemExit("navigation_classifier: no unsafe step in the demonstrations")
        self.train(PRETRAIN)

    def _labelled(self, states: np.ndarray, unsafe: bool) -> tuple[np.ndarray, np.ndarray]:
        x = windows(((states - self.mean) * self.inv_std).astype(np.float32))
        return x, labels(len(states), unsafe, self.horizon)

    def _index(self) -> None:
        data = self.demos + list(self.own[0]) + list(self.own[1])
        self.x = np.concatenate([x for x, _ in data])
        y = np.concatenate([y for _, y in data])
        self.index = [np.flatnonzero(y < 0.5), np.flatnonzero(y > 0.5)]

    def train(self, steps: int) -> None:
        if not (len(self.index[0]) and len(self.index[1])):
            return
        y = np.tile(np.array([0.0, 1.0], dtype=np.float32), BATCH // 2)  # row r: class r % 2
        for _ in range(steps):
            safe = self.index[0][self.rng.integers(0, len(self.index[0]), BATCH // 2)]
            unsafe = self.index[1][self.rng.integers(0, len(self.index[1]), BATCH // 2)]
            rows = np.empty(BATCH, dtype=np.int64)
            rows[0::2], rows[1::2] = safe, unsafe
            self.net.step(self.x[rows], y)

    def probabilities(self, states: np.ndarray) -> np.ndarray:
        """The probability at every step of an episode (the network does not change within one)."""
        x = windows(((states - self.mean) * self.inv_std).astype(np.float32))
        with np.errstate(over="ignore"):
            return 1.0 / (1.0 + np.exp(-self.net.logits(x).astype(np.float64)))

    def end(self, states: np.ndarray, unsafe: bool) -> None:
        """An episode it did not end: with own episodes on, it joins its group, then UPDATE steps."""
        if self.keep is None:
            return
        group = self.own[int(unsafe)]
        if len(group) == self.keep:
            group.popleft()
        group.append(self._labelled(states, unsafe))
        self._index()
        self.train(UPDATE)


def replay(make, episodes: list, thresholds: tuple[float, ...], learns: bool = True) -> dict[float, dict]:
    """Replays `episodes` in order through a classifier built by `make()` and measures it as the
    screen does, per threshold: a new classifier for each when it `learns` from its own episodes
    (which ones join depends on which were ended), else one for all."""
    out = {}
    shared = None if learns else make()
    for thr in thresholds:
        clf = shared if shared is not None else make()
        caught = alarms = 0
        leads = []
        for states, unsafe in episodes:
            fired = np.flatnonzero(clf.probabilities(states) > thr)
            if fired.size:
                caught += unsafe
                alarms += not unsafe
                if unsafe:
                    leads.append(len(states) - int(fired[0]))
            else:
                clf.end(states, unsafe)
        n_unsafe = sum(u for _, u in episodes)
        n_safe = len(episodes) - n_unsafe
        out[thr] = {
            "caught_pct": 100.0 * caught / n_unsafe if n_unsafe else float("nan"),
            "false_alarm_pct": 100.0 * alarms / n_safe if n_safe else float("nan"),
            "mean_lead": float(np.mean(leads)) if leads else float("nan"),
            "caught": caught, "unsafe": n_unsafe, "false_alarms": alarms, "safe": n_safe,
        }
    return out


def cross_validate(demos: list, horizon: int, seed: int) -> dict[float, dict]:
    """5 folds of the demonstrations (every 5th of each group), `demos` variant; counts pooled."""
    safe = [d for d in demos if not d[1]]
    unsafe = [d for d in demos if d[1]]
    pooled = {thr: {"caught": 0, "unsafe": 0, "false_alarms": 0, "safe": 0, "leads": []} for thr in THRESHOLDS}
    for k in range(FOLDS):
        held = safe[k::FOLDS] + unsafe[k::FOLDS]
        train = [d for i, d in enumerate(safe) if i % FOLDS != k] + [d for i, d in enumerate(unsafe) if i % FOLDS != k]
        clf = Classifier(train, horizon, seed * 1000 + k)
        for states, u in held:
            p = clf.probabilities(states)
            for thr in THRESHOLDS:
                fired = np.flatnonzero(p > thr)
                acc = pooled[thr]
                acc["unsafe" if u else "safe"] += 1
                if fired.size:
                    acc["caught" if u else "false_alarms"] += 1
                    if u:
                        acc["leads"].append(len(states) - int(fired[0]))
    return {
        thr: {
            "caught_pct": 100.0 * a["caught"] / a["unsafe"],
            "false_alarm_pct": 100.0 * a["false_alarms"] / a["safe"],
            "mean_lead": float(np.mean(a["leads"])) if a["leads"] else float("nan"),
            **{k: a[k] for k in ("caught", "unsafe", "false_alarms", "safe")},
        }
        for thr, a in pooled.items()
    }


def summarise(runs: list[dict]) -> dict:
    """Mean and range over seeds of each measure."""
    out = {}
    for key in ("caught_pct", "false_alarm_pct", "mean_lead"):
        xs = np.array([r[key] for r in runs], dtype=np.float64)
        finite = xs[np.isfinite(xs)]
        out[key] = round(float(finite.mean()), 1) if finite.size else None
        out[key + "_range"] = [round(float(finite.min()), 1), round(float(finite.max()), 1)] if finite.size else None
    return out


def choose(cv: dict[tuple[int, float], dict]) -> tuple[int, float]:
    """The rule of the module's docstring, on the cross-validated means."""
    ok = [k for k, s in cv.items() if s["false_alarm_pct"] <= MAX_FALSE_ALARMS]
    if ok:
        return min(ok, key=lambda k: (-cv[k]["caught_pct"], cv[k]["false_alarm_pct"], k[0], -k[1]))
    return min(cv, key=lambda k: (cv[k]["false_alarm_pct"], k[0], -k[1]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--demos", required=True, help="the training demonstrations (.npz)")
    parser.add_argument("--episodes", required=True, help="the held-out episodes, replayed in order (.npz)")
    parser.add_argument("--seeds", type=int, default=5, help="classifier seeds 0..N-1 (default 5)")
    parser.add_argument("--out", required=True, help="the summary (.json)")
    parser.add_argument("--csv", required=True, help="every run (.csv)")
    args = parser.parse_args(argv)
    demos, held = load(args.demos), load(args.episodes)
    seeds = range(args.seeds)
    rows, cv_runs, held_runs = [], {}, {}
    for h in HORIZONS:
        for seed in seeds:
            for thr, r in cross_validate(demos, h, seed).items():
                cv_runs.setdefault((h, thr), []).append(r)
                rows.append(["cv", "demos", h, thr, seed, r])
            for variant, keep in (("demos", None), ("own50", KEEP)):
                made = replay(lambda: Classifier(demos, h, seed, keep), held, THRESHOLDS, learns=keep is not None)
                for thr, r in made.items():
                    held_runs.setdefault((variant, h, thr), []).append(r)
                    rows.append(["heldout", variant, h, thr, seed, r])
            print(f"navigation_classifier: H {h} seed {seed} done", flush=True)
    cv = {k: summarise(v) for k, v in cv_runs.items()}
    chosen = choose(cv)
    out = {
        "rule": "5-fold cross-validation on the demonstrations; the highest caught % with at most "
        f"{MAX_FALSE_ALARMS:g}% false alarms (ties: fewer false alarms, smaller H, higher threshold)",
        "seeds": args.seeds,
        "demos": args.demos, "episodes": args.episodes,
        "chosen": {"horizon": chosen[0], "threshold": chosen[1]},
        "cross_validation": [{"horizon": h, "threshold": t, **s} for (h, t), s in sorted(cv.items())],
        "heldout": [
            {"variant": v, "horizon": h, "threshold": t, "chosen": (h, t) == chosen, **summarise(rs),
             "unsafe": rs[0]["unsafe"], "safe": rs[0]["safe"]}
            for (v, h, t), rs in sorted(held_runs.items())
        ],
    }
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    with open(args.csv, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["split", "variant", "horizon", "threshold", "seed", "caught_pct", "false_alarm_pct", "mean_lead",
                    "caught", "unsafe", "false_alarms", "safe"])
        for split, variant, h, thr, seed, r in rows:
            w.writerow([split, variant, h, thr, seed, f"{r['caught_pct']:.2f}", f"{r['false_alarm_pct']:.2f}",
                        f"{r['mean_lead']:.2f}", r["caught"], r["unsafe"], r["false_alarms"], r["safe"]])
    print(json.dumps({"chosen": out["chosen"], "heldout": [r for r in out["heldout"] if r["chosen"]]}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
