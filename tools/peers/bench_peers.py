#!/usr/bin/env python3
"""Side-by-side training throughput: `defender train` against Stable-Baselines3 (PyTorch) and
SBX (JAX), SAC and TD3, and against OmniSafe's SACLag (`saclag`: our SAC with the Lagrangian at
the cost limit 25 on a velocity task), in one script run so that every figure sees the same
machine load. `make bench-peers` installs SB3 and SBX and runs this; `make bench-omnisafe`
installs OmniSafe (tools/peers/omnisafe-venv.sh) and runs it with `--peers omnisafe`.

Protocol, the same for all: Hopper-v5, the libraries' defaults (256x256 networks,
batch 256, one gradient step per environment step), `learning_starts` (1000) uniformly random
steps, then `warmup` (1000) steps with updates, untimed, then `measured` (2000) timed steps,
environment, replay buffer, update and bookkeeping included; the same number of threads for
everyone (with fewer threads than CPUs, every process is also pinned to the first `threads` CPUs).

`defender train` runs as a user runs it (run directory, checkpoints every 2 minutes, metrics
files); its rate comes from `metrics.csv`, whose rows carry the wall-clock seconds at each
episode's end: (steps between the last episode ending by step learning_starts + warmup and the
last recorded episode) / (seconds between them). SB3 and SBX time the same steps with a callback
(tools/peers/sb3_speed.py). OmniSafe runs as tools/peers/omnisafe_saclag.py runs it (its own defaults, epochs
of 1,000 steps, `--start-learning-steps` = learning_starts) and is timed as we are, from the wall
seconds at each episode's end in its episodes.csv. Its SACLag updates the actor every second step
(`policy_delay` 2) and keeps alpha fixed: less work a step than our SAC, which updates both every
step and learns alpha.

    .deps/tools-venv/bin/python tools/peers/bench_peers.py [--algos sac,td3] [--peers sb3,sbx] [--threads 2]
        [--repeats 1] [--defender target/release/defender] [--env Hopper-v5]
    python3 tools/peers/bench_peers.py --env SafetyHopperVelocity-v1 --algos sac,saclag --peers omnisafe \
        --threads 1 --repeats 3      (OmniSafe from .deps/omnisafe-venv)
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

ROOT = Path(__file__).resolve().parents[2]


def pin(threads: int):
    """A preexec_fn restricting the child to the first `threads` CPUs, if fewer than all."""
    cpus = sorted(os.sched_getaffinity(0))
    if threads >= len(cpus):
        return None
    chosen = set(cpus[:threads])
    return lambda: os.sched_setaffinity(0, chosen)


OMNISAFE_PYTHON = ROOT / ".deps" / "omnisafe-venv" / "bin" / "python"
# Our Lagrangian SAC's cost limit in the `saclag` arm: the velocity tasks' episode limit.
COST_LIMIT = 25.0


def defender_rate(binary: str, env_id: str, algo: str, a: argparse.Namespace, work: Path) -> dict:
    run = work / f"defender-{algo}-{time.monotonic_ns()}"
    config = work / f"{run.name}.toml"
    total = a.learning_starts + a.warmup + a.measured
    agent = "sac" if algo == "saclag" else algo
    safety = f'\n[safety]\nmethod = "lagrangian"\ncost_limit = {COST_LIMIT}\n' if algo == "saclag" else ""
    config.write_text(
        f'env = "{env_id}"\nalgo = "{agent}"\nseed = 0\ntotal_steps = {total}\n\n'
        f"[{agent}]\nlearning_starts = {a.learning_starts}\n{safety}"
    )
    env = dict(os.environ, DEFENDER_NN_THREADS=str(a.threads))
    done = subprocess.run(
        [binary, "train", "--config", str(config), "--out", str(run)],
        env=env, preexec_fn=pin(a.threads), capture_output=True, text=True,
    )
    if done.returncode != 0:
        raise SystemExit(f"defender train failed ({done.returncode}):\n{done.stderr}")
    rate = episode_rate(run / "metrics.csv", a)
    version = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.strip()
    shutil.rmtree(run, ignore_errors=True)
    return {**rate, "version": version}


def episode_rate(path: Path, a: argparse.Namespace) -> dict:
    """Steps/s from a file of episode ends (total_steps, wall_seconds): from the last episode
    ending by step learning_starts + warmup to the last episode."""
    with open(path) as f:
        rows = [(int(r["total_steps"]), float(r["wall_seconds"])) for r in csv.DictReader(f)]
    start = a.learning_starts + a.warmup
    before = [r for r in rows if r[0] <= start]
    if not before or rows[-1][0] - before[-1][0] < a.measured // 2:
        raise SystemExit(f"{path}: too few episode ends to time steps {start}..{start + a.measured}")
    (s0, t0), (s1, t1) = before[-1], rows[-1]
    return {"steps_per_second": (s1 - s0) / (t1 - t0), "seconds": t1 - t0, "steps": s1 - s0}


def omnisafe_rate(env_id: str, algo: str, a: argparse.Namespace, work: Path) -> dict | None:
    """OmniSafe's SACLag through tools/peers/omnisafe_saclag.py, timed from its episodes.csv."""
    if algo != "saclag":
        return None
    if not OMNISAFE_PYTHON.is_file():
        raise SystemExit(f"{OMNISAFE_PYTHON}: missing (bash tools/peers/omnisafe-venv.sh)")
    out = work / f"omnisafe-{time.monotonic_ns()}"
    epoch = 1000
    total = -(-(a.learning_starts + a.warmup + a.measured) // epoch) * epoch
    cmd = [
        str(OMNISAFE_PYTHON), str(ROOT / "tools" / "peers" / "omnisafe_saclag.py"), "--env", env_id, "--seed", "0",
        "--steps", str(total), "--steps-per-epoch", str(epoch), "--start-learning-steps", str(a.learning_starts),
        "--cost-limit", str(COST_LIMIT), "--threads", str(a.threads), "--out", str(out),
    ]
    env = dict(os.environ, OMP_NUM_THREADS=str(a.threads), MKL_NUM_THREADS=str(a.threads))
    done = subprocess.run(cmd, env=env, preexec_fn=pin(a.threads), capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"omnisafe saclag failed ({done.returncode}):\n{done.stderr[-4000:]}")
    rate = episode_rate(out / "episodes.csv", a)
    versions = json.loads((out / "run.json").read_text())["versions"]
    shutil.rmtree(out, ignore_errors=True)
    return {**rate, "version": f"omnisafe {versions['omnisafe']}, torch {versions['torch']}"}


def peer_rate(lib: str, env_id: str, algo: str, a: argparse.Namespace) -> dict:
    cmd = [
        sys.executable, str(ROOT / "tools" / "peers" / "sb3_speed.py"), algo, env_id, str(a.measured),
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
    p.add_argument("--algos", default="sac,td3", help="sac, td3, saclag (Lagrangian SAC, a cost task)")
    p.add_argument("--peers", default="sb3,sbx", help="sb3, sbx, omnisafe")
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
                    if lib == "defender":
                        r = defender_rate(a.defender, a.env, algo, a, Path(tmp))
                    elif lib == "omnisafe":
                        r = omnisafe_rate(a.env, algo, a, Path(tmp))
                    else:
                        r = None if algo == "saclag" else peer_rate(lib, a.env, algo, a)
                    if r is None:  # the peer has no such algorithm
                        continue
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
        med = {lib: statistics.median(rates[(lib, algo)]) for lib in libs if rates[(lib, algo)]}
        spread = {lib: f" ({min(rates[(lib, algo)]):.1f}-{max(rates[(lib, algo)]):.1f})" if a.repeats > 1 else ""
                  for lib in med}
        cells = [f"{med[lib]:.1f}{spread[lib]}" if lib in med else "-" for lib in libs]
        # The ratio repeat by repeat (each pair ran back to back, under the same load): its
        # median and spread, which the host's drift moves less than the medians' ratio.
        def ratio(x: str) -> str:
            pairs = [d / p for d, p in zip(rates[("defender", algo)], rates[(x, algo)])]
            if not pairs:
                return "-"
            extra = f" ({min(pairs):.2f}-{max(pairs):.2f})" if len(pairs) > 1 else ""
            return f"{statistics.median(pairs):.2f}x{extra}"

        cells += [ratio(x) for x in libs[1:]]
        print(f"| {algo.upper()} | " + " | ".join(cells) + " |")
    print("(steps/s: median (min-max) of the repeats; ratios: defender / peer repeat by repeat, median (min-max))"
          if a.repeats > 1 else "(steps/s)")
    for lib in libs:
        print(f"{lib}: {versions.get(lib, 'not run')}")


if __name__ == "__main__":
    main()
