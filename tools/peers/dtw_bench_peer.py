#!/usr/bin/env python3
"""Side-by-side batch DTW speed: defender-dtw vs dtaidistance's C `dtw_ndim.distance_fast`.

Both align the same two random walks (n x m x d, default 1000 x 1000 x 11) in one run of this
script, one core each, best of several runs, timing thread CPU time as well as wall time (the
machine is shared). Ours runs as the example binary `dtw_speed` (f32); dtaidistance gets float64
(what it requires). Also checks our cost against dtw-python (symmetric1, euclidean).

Note: dtaidistance's ndim local cost is the squared Euclidean distance and it returns the square
root of the total (a different quantity from SPEC section 2, same number of DP cells, less work
per cell: no square root per cell). Throughput is DP cells (n * m) per second.

Run:
    cargo build --release -p defender-dtw --example dtw_speed
    .deps/tools-venv/bin/python tools/peers/dtw_bench_peer.py [--n 1000 --m 1000 --d 11]
         [--bin $CARGO_TARGET_DIR/release/examples/dtw_speed]
"""

import argparse
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from dtaidistance import dtw_ndim
from dtw import dtw as dtw_python


def best_of(fn, runs):
    wall, cpu, out = float("inf"), float("inf"), None
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.thread_time()
        out = fn()
        cpu = min(cpu, time.thread_time() - c0)
        wall = min(wall, time.perf_counter() - t0)
    return wall, cpu, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--m", type=int, default=1000)
    ap.add_argument("--d", type=int, default=11)
    ap.add_argument("--runs", type=int, default=10)
    target = os.environ.get("CARGO_TARGET_DIR", str(Path(__file__).resolve().parents[2] / "target"))
    ap.add_argument("--bin", default=str(Path(target) / "release/examples/dtw_speed"))
    a = ap.parse_args()

    rng = np.random.default_rng(7)
    x = np.cumsum(rng.uniform(-0.5, 0.5, size=(a.n, a.d)), axis=0).astype(np.float32)
    y = np.cumsum(rng.uniform(-0.5, 0.5, size=(a.m, a.d)), axis=0).astype(np.float32)
    cells = a.n * a.m

    x64, y64 = x.astype(np.float64), y.astype(np.float64)
    wall, cpu, peer = best_of(lambda: dtw_ndim.distance_fast(x64, y64), a.runs)
    print(f"dtaidistance {dtw_ndim.__name__}.distance_fast (C, f64): {a.n}x{a.m}x{a.d} "
          f"wall {wall * 1e3:.3f} ms = {cells / wall / 1e6:.1f} M cells/s, "
          f"cpu {cpu * 1e3:.3f} ms = {cells / cpu / 1e6:.1f} M cells/s")

    with tempfile.TemporaryDirectory() as tmp:
        xf, yf = Path(tmp) / "x.f32", Path(tmp) / "y.f32"
        x.astype("<f4").tofile(xf)
        y.astype("<f4").tofile(yf)
        out = subprocess.run([a.bin, "batch", str(a.n), str(a.m), str(a.d), str(xf), str(yf)],
                             check=True, capture_output=True, text=True).stdout
    fields = dict(kv.split("=") for kv in out.split())
    ours_wall, ours_cpu = float(fields["seconds"]), float(fields["cpu_seconds"])
    print(f"defender-dtw dtw (Rust, f32):                {a.n}x{a.m}x{a.d} "
          f"wall {ours_wall * 1e3:.3f} ms = {cells / ours_wall / 1e6:.1f} M cells/s, "
          f"cpu {ours_cpu * 1e3:.3f} ms = {cells / ours_cpu / 1e6:.1f} M cells/s")
    print(f"speed-up (ours / dtaidistance): wall {wall / ours_wall:.1f}x, cpu {cpu / ours_cpu:.1f}x")

    want = dtw_python(x64, y64, dist_method="euclidean", step_pattern="symmetric1").distance
    ours = float(fields["cost"])
    print(f"cost: ours {ours:.6f}, dtw-python {want:.6f} (relative difference {abs(ours - want) / want:.2e}); "
          f"dtaidistance (sqrt of squared-cost DTW, another quantity) {peer:.6f}")


if __name__ == "__main__":
    main()
