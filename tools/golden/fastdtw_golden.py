#!/usr/bin/env python3
"""Golden FastDTW values for defender-dtw from the PyPI `fastdtw` package, version 0.3.4.

Writes crates/defender-dtw/tests/data/fastdtw_golden.txt, read by tests/fastdtw_golden.rs. Each
case is three lines:

    case <name> <n> <m> <dim> <setting>=<distance> ...
    <x: n * dim float32 values, row-major>
    <y: m * dim float32 values>

A setting is `r<radius>-<l1|l2>` (`fastdtw(x, y, radius=radius, dist=None | 2)[0]`) or
`exact-<l1|l2>` (`dtw(x, y, dist=None | 2)[0]`, the package's full DTW); a distance is the
float64 `repr`, or `error` where the package raises (radius 0 with an odd coarsened length makes it
raise IndexError). Inputs are float32, given to the package as float32 arrays: it converts them to
float64, as the authors' code did with its observations.

This is the module a normal `pip install fastdtw==0.3.4` imports: PyPI has only the source
archive, whose build (isolated, without numpy) cannot compile the Cython extension and installs
the pure-Python `fastdtw/fastdtw.py` (see docs/decisions-authors.md). The script refuses to run against
the compiled extension, whose windows and tie-breaking differ.

Run: .deps/tools-venv/bin/python tools/golden/fastdtw_golden.py   (fastdtw 0.3.4, numpy)
"""

from pathlib import Path

import fastdtw
import numpy as np

OUT = Path(__file__).resolve().parents[2] / "crates/defender-dtw/tests/data/fastdtw_golden.txt"
SETTINGS = [(r, p) for r in (0, 1, 2) for p in ("l1", "l2")]


def sequences(rng, n, m, dim, kind):
    if kind == "walk":
        # Random walks, like trajectories, with an offset between the two.
        x = np.cumsum(rng.normal(size=(n, dim)), axis=0)
        y = np.cumsum(rng.normal(size=(m, dim)), axis=0) + 0.5
    else:
        # Small integers: many equal costs, so the package's tie-breaking decides the path.
        x = rng.integers(-2, 3, size=(n, dim))
        y = rng.integers(-2, 3, size=(m, dim))
    return x.astype(np.float32), y.astype(np.float32)


def cases(rng):
    # (name, n, m, dim, kind)
    for n in range(1, 13):
        for m in (1, 2, 3, 4, 5, 7, 8, 9, 16, 17):
            yield f"small_{n}x{m}", n, m, int(rng.choice([1, 3, 11])), "walk"
    for i in range(60):
        n, m = (int(v) for v in rng.integers(1, 61, size=2))
        yield f"walk_{i}", n, m, (1, 3, 11)[i % 3], "walk"
    for i in range(40):
        n, m = (int(v) for v in rng.integers(1, 61, size=2))
        yield f"ties_{i}", n, m, (1, 3, 11)[i % 3], "ties"
    for n, m, dim in ((20, 1000, 11), (1000, 20, 3), (20, 999, 3), (17, 500, 1), (20, 300, 17)):
        yield f"long_{n}x{m}", n, m, dim, "walk"
    yield "long_ties_20x400", 20, 400, 3, "ties"


def distance(fn, *args, **kwargs):
    try:
        return repr(float(fn(*args, **kwargs)[0]))
    except IndexError:
        return "error"


def main():
    if fastdtw.fastdtw.__module__ != "fastdtw.fastdtw":
        raise SystemExit(f"expected the pure-Python fastdtw module, got {fastdtw.fastdtw.__module__}")
    rng = np.random.default_rng(20240623)
    lines = []
    for name, n, m, dim, kind in cases(rng):
        x, y = sequences(rng, n, m, dim, kind)
        results = []
        for radius, p in SETTINGS:
            dist = None if p == "l1" else 2
            results.append(f"r{radius}-{p}={distance(fastdtw.fastdtw, x, y, radius=radius, dist=dist)}")
        for p in ("l1", "l2"):
            results.append(f"exact-{p}={distance(fastdtw.dtw, x, y, dist=None if p == 'l1' else 2)}")
        lines.append(f"case {name} {n} {m} {dim} " + " ".join(results))
        lines.append(" ".join(str(v) for v in x.ravel()))
        lines.append(" ".join(str(v) for v in y.ravel()))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT} ({len(lines) // 3} cases)")


if __name__ == "__main__":
    main()
