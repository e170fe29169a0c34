#!/usr/bin/env bash
# The paper's ablation study end to end: bare SAC runs with their episodes recorded
# (experiments/ablation.toml, resumable), then the 576 strategies ranked per task and by the mean
# score over the three tasks, for state and for state-action trajectories.
#
#   bash scripts/ablation.sh [OUT]        (default OUT: results/ablation)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-results/ablation}
cargo build --release -p defender-cli
BIN=target/release/defender
"$BIN" sweep experiments/ablation.toml --out "$OUT"
for mode in state state-action; do
  ranked=()
  for env in InvertedDoublePendulum-v5 Hopper-v5 Walker2d-v5; do
    echo "== $env ($mode) =="
    "$BIN" ablate --demos "data/demos/$env.npz" --episodes "$OUT/$env/sac-bare-s0/episodes.npz" \
      --mode "$mode" --out "$OUT/$env-$mode.csv"
    ranked+=("$OUT/$env-$mode.csv")
  done
  echo "== ranking by the mean score over the three tasks ($mode) =="
  "$BIN" ablate --combine "${ranked[@]}" --out "$OUT/$mode.csv"
done
