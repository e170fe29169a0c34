#!/usr/bin/env bash
# `defender sweep --jobs 2` against `--jobs 1` on a grid of equal runs (bare SAC on
# InvertedDoublePendulum-v5, 4 seeds, STEPS steps each), wall time of each, and the ratio.
# The target: --jobs 2 in at most 60% of the wall time of --jobs 1 on 2 cores.
#
#   bash scripts/bench-sweep.sh [STEPS]      (default 4000; run it on an otherwise idle machine)
set -euo pipefail
cd "$(dirname "$0")/.."
STEPS=${1:-4000}
cargo build --release -p defender-cli >/dev/null 2>&1 || cargo build --release -p defender-cli
BIN=target/release/defender
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/grid.toml" <<TOML
description = "bench: 4 equal bare SAC runs"
[grid]
envs = ["InvertedDoublePendulum-v5"]
strategies = ["none"]
seeds = [0, 1, 2, 3]
[budget]
steps = $STEPS
TOML
time_of() {
  local start end
  start=$(date +%s.%N)
  "$BIN" sweep "$work/grid.toml" --out "$work/jobs$1" --jobs "$1" 2>/dev/null
  end=$(date +%s.%N)
  python3 -c "print($end - $start)"
}
t1=$(time_of 1)
t2=$(time_of 2)
echo "cores: $(nproc), $(lscpu | sed -n 's/^Model name: *//p')"
python3 -c "print(f'jobs 1: {$t1:.1f} s\njobs 2: {$t2:.1f} s\nratio: {100 * $t2 / $t1:.0f}% (target <= 60%)')"
