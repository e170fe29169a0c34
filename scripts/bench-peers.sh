#!/usr/bin/env bash
# `make bench-peers`: training throughput of `defender train` beside Stable-Baselines3 (PyTorch)
# and SBX (JAX), SAC and TD3 on Hopper-v5, in one script run (tools/peers/bench_peers.py). Installs the
# peers into .deps/tools-venv first (scripts/tools-venv.sh: a multi-GB download the first time).
# Extra arguments go to tools/peers/bench_peers.py, e.g. BENCH_ARGS="--threads 1 --repeats 3".
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/tools-venv.sh
${CARGO:-cargo} build --release -p defender-cli
echo "bench-peers: load average $(cut -d' ' -f1-3 /proc/loadavg) (figures move with the machine's load)"
# shellcheck disable=SC2086
.deps/tools-venv/bin/python tools/peers/bench_peers.py ${BENCH_ARGS:-}
