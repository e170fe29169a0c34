#!/usr/bin/env python3
"""Side-by-side training throughput: `defender train` against Stable-Baselines3 (PyTorch) and
SBX (JAX), SAC and TD3, in one script run so that every figure sees the same machine load.
`make bench-peers` installs the peers and runs this.

Protocol, the same for all (issue 15): Hopper-v5, the libraries' defaults (256x256 networks,
batch 256, one gradient step per environment step), `learning_starts` (1000) uniformly random
steps, then `warmup` (1000) steps with updates, untimed, then `measured` (2000) timed steps,
environment, replay buffer, update and bookkeeping included; the same number of threads for
everyone (with fewer threads than CPUs, every process is also pinned to the first `threads` CPUs).

`defender train` runs as a user runs it (run directory, checkpoints every 2 minutes, metrics
files); its rate comes from `metrics.csv`, whose rows carry the wall-clock seconds at each
episode's end: (steps between the last episode ending by step learning_starts + warmup and the
last recorded episode) / (seconds between them). The peers time the same steps with a callback
(tools/sb3_speed.py).

    .deps/tools-venv/bin/python tools/bench_peers.py [--algos sac,td3] [--peers sb3,sbx] [--threads 2]
        [--repeats 1] [--defender target/release/defender] [--env Hopper-v5]
"""

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def pin(threads: int):
    """A preexec_fn restricting the child to the first `threads` CPUs, if fewer than all."""
    cpus = sorted(os.sched_getaffinity(0))
    if threads >= len(cpus):
        return None
    chosen = set(cpus[:threads])
    return lambda: os.sched_setaffinity(0, chosen)


def defender_rate(binary: str, env_id: str, algo: str, a: argparse.Namespace, work: Path) -> dict:
    run = work / f"defender-{algo}-{time.monotonic_ns()}"
    config = work / f"{run.name}.toml"
    total = a.learning_starts + a.warmup + a.measured
    config.write_text(
        f'env = "{env_id}"\nalgo = "{algo}"\nseed = 0\ntotal_steps = {total}\n\n'
        f"[{algo}]\nlearning_starts = {a.learning_starts}\n"
    )
    env = dict(os.environ, DEFENDER_NN_THREADS=str(a.threads))
    done = subprocess.run(
        [binary, "train", "--config", str(config), "--out", str(run)],
        env=env, preexec_fn=pin(a.threads), capture_output=True, text=True,
    )
    if done.returncode != 0:
        raise SystemExit(f"defender train failed ({done.returncode}):\n{done.stderr}")
    with open(run / "metrics.csv") as f:
        rows = [(int(r["total_steps"]), float(r["wall_seconds"])) for r in csv.DictReader(f)]
    start = a.learning_starts + a.warmup
    before = [r for r in rows if r[0] <= start]
    if not before or rows[-1][0] - before[-1][0] < a.measured // 2:
        raise SystemExit(f"{run}/metrics.csv: too few episode ends to time steps {start}..{total}")
    (s0, t0), (s1, t1) = before[-1], rows[-1]
    version = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.strip()
    shutil.rmtree(run, ignore_errors=True)
    return {"steps_per_second": (s1 - s0) / (t1 - t0), "seconds": t1 - t0, "steps": s1 - s0, "version": version}


def peer_rate(lib: str, env_id: str, algo: str, a: argparse.Namespace) -> dict:
    cmd = [
        sys.executable, str(ROOT / "tools" / "sb3_speed.py"), algo, env_id, str(a.measured),
        str(a.learning_starts), str(a.threads), "--lib", lib, "--warmup", str(a.warmup), "--json",
    ]
    env = dict(os.environ, OMP_NUM_THREADS=str(a.threads), MKL_NUM_THREADS=str(a.threads),
               JAX_PLATFORMS="cpu", TF_CPP_MIN_LOG_LEVEL="2")
    done = subprocess.run(cmd, env=env, preexec_fn=pin(a.threads), capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{lib} {algo} failed ({done.returncode}):\n{done.stderr[-4000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def cpu_model() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--algos", default="sac,td3")
    p.add_argument("--peers", default="sb3,sbx")
    p.add_argument("--env", default="Hopper-v5")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--learning-starts", type=int, default=1000)
    p.add_argument("--warmup", type=int, default=1000)
    p.add_argument("--measured", type=int, default=2000)
    p.add_argument("--repeats", type=int, default=1, help="runs of each; the table shows their median")
    p.add_argument("--defender", default=str(ROOT / "target" / "release" / "defender"))
    a = p.parse_args()
    algos = [x for x in a.algos.split(",") if x]
    libs = ["defender"] + [x for x in a.peers.split(",") if x]
    if not Path(a.defender).is_file():
        raise SystemExit(f"{a.defender}: no such binary (cargo build --release -p defender-cli)")
    print(f"machine: {os.cpu_count()} CPUs, {cpu_model()}; load average at the start {load()}", flush=True)
    rates = {(lib, algo): [] for lib in libs for algo in algos}
    versions = {}
    with tempfile.TemporaryDirectory(prefix="bench-peers-") as tmp:
        for rep in range(a.repeats):
            for algo in algos:
                for lib in libs:  # interleaved: every library sees the same load
                    r = (defender_rate(a.defender, a.env, algo, a, Path(tmp)) if lib == "defender"
                         else peer_rate(lib, a.env, algo, a))
                    rates[(lib, algo)].append(r["steps_per_second"])
                    versions[lib] = r["version"]
                    print(f"  run {rep + 1}/{a.repeats} {lib:8} {algo}: {r['steps_per_second']:7.1f} steps/s "
                          f"(load {load()})", flush=True)
    print()
    print(f"{a.env}, {a.learning_starts} random + {a.warmup} warm-up + {a.measured} timed steps, "
          f"{a.threads} thread(s), median of {a.repeats}; load average at the end {load()}")
    head = f"| algo | {' | '.join(libs)} | " + " | ".join(f"defender / {x}" for x in libs[1:]) + " |"
    print(head)
    print("|" + "---|" * (1 + len(libs) + len(libs) - 1))
    for algo in algos:
        med = {lib: statistics.median(rates[(lib, algo)]) for lib in libs}
        cells = [f"{med[lib]:.1f}" for lib in libs] + [f"{med['defender'] / med[x]:.2f}x" for x in libs[1:]]
        print(f"| {algo.upper()} | " + " | ".join(cells) + " |")
    print("(steps/s)")
    for lib in libs:
        print(f"{lib}: {versions[lib]}")


if __name__ == "__main__":
    main()
