#!/usr/bin/env python3
"""Golden DTW values for defender-dtw from dtw-python (an independent implementation).

Writes crates/defender-dtw/tests/data/dtw_golden.txt, read by tests/golden.rs. Each case is three
lines: `case <name> <n> <m> <dim> <band or -1> <distance>`, then x and y (row-major float32
values, printed exactly). Distances are dtw-python's
    dtw(x, y, dist_method="euclidean", step_pattern="symmetric1"[, window_type="sakoechiba",
        window_args={"window_size": band}]).distance
computed in float64 from the float32 inputs.

Run: .deps/tools-venv/bin/python tools/golden/dtw_golden.py   (dtw-python 1.9.0, numpy)
"""

from pathlib import Path

import numpy as np
from dtw import dtw

OUT = Path(__file__).resolve().parents[2] / "crates/defender-dtw/tests/data/dtw_golden.txt"


def cases(rng):
    # (name, n, m, dim, band)
    shapes = [
        ("one_by_one", 1, 1, 1, None),
        ("one_by_many", 1, 17, 3, None),
        ("many_by_one", 23, 1, 2, None),
        ("square_d1", 50, 50, 1, None),
        ("rect_d11", 37, 90, 11, None),
        ("rect_d11_t", 90, 37, 11, None),
        ("hopper_like", 200, 160, 11, None),
        ("long_d5", 400, 350, 5, None),
        ("odd_d17", 33, 61, 17, None),
        ("band_5", 60, 64, 4, 5),
        ("band_0_square", 40, 40, 3, 0),
        ("band_20", 150, 140, 11, 20),
    ]
    for name, n, m, dim, band in shapes:
        # Random walks, like trajectories, plus an offset between the two.
        x = np.cumsum(rng.normal(size=(n, dim)), axis=0).astype(np.float32)
        y = (np.cumsum(rng.normal(size=(m, dim)), axis=0) + 0.5).astype(np.float32)
        yield name, x, y, band


def main():
    rng = np.random.default_rng(20240611)
    lines = []
    for name, x, y, band in cases(rng):
        kwargs = {"dist_method": "euclidean", "step_pattern": "symmetric1"}
        if band is not None:
            kwargs.update(window_type="sakoechiba", window_args={"window_size": band})
        d = dtw(x.astype(np.float64), y.astype(np.float64), **kwargs).distance
        n, dim = x.shape
        m = y.shape[0]
        lines.append(f"case {name} {n} {m} {dim} {-1 if band is None else band} {float(d)!r}")
        lines.append(" ".join(repr(float(v)) for v in x.ravel()))
        lines.append(" ".join(repr(float(v)) for v in y.ravel()))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT} ({len(lines) // 3} cases)")


if __name__ == "__main__":
    main()
