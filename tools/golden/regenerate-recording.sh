#!/usr/bin/env bash
# Regenerates the training episodes a committed run recorded (its `record_episodes` file, which
# git ignores: results/**/*.npz) by training its configuration again. A run is deterministic
# under its seed and nothing before a step depends on the budget, so the first STEPS steps of the
# new run are the committed run's, bit for bit; this checks it on metrics.csv (every column but
# wall_seconds) before it says the recording is the one the docs' screens read.
#
#   tools/golden/regenerate-recording.sh RUN_DIR STEPS OUT_DIR
#   e.g. tools/golden/regenerate-recording.sh results/velocity/SafetyHopperVelocity-v1/sac-bare-s0 100000 /tmp/hopper-s0
#
# writes OUT_DIR/episodes.npz (the recording) and OUT_DIR/run/ (the new run). STEPS is the part a
# screen reads (docs/results-velocity.md: the first 100k steps). DEFENDER is the `defender`
# command on PATH, else target/release/defender.
set -euo pipefail
if [ $# -ne 3 ]; then
  sed -n '2,14p' "$0" >&2
  exit 2
fi
run=$1 steps=$2 out=$3
cd "$(dirname "$0")/../.."
defender=${DEFENDER:-$(command -v defender || echo target/release/defender)}
[ -f "$run/config.toml" ] && [ -f "$run/metrics.csv" ] || { echo "regenerate: $run is not a run directory" >&2; exit 1; }
mkdir -p "$out"
rm -rf "$out/run" "$out/episodes.npz"
"$defender" train --config "$run/config.toml" --steps "$steps" --record-episodes "$out/episodes.npz" \
  --out "$out/run"
# metrics.csv without wall_seconds (found by name), the committed rows cut to the new run's count.
strip() { awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "wall_seconds") w = i }
  { line = ""; for (i = 1; i <= NF; i++) if (i != w) line = line (line == "" ? "" : ",") $i; print line }' "$1"; }
n=$(wc -l < "$out/run/metrics.csv")
if diff <(strip "$run/metrics.csv" | head -n "$n") <(strip "$out/run/metrics.csv") > "$out/metrics.diff"; then
  echo "regenerate: $((n - 1)) episodes equal the committed run's; the recording is $out/episodes.npz"
else
  echo "regenerate: the new run differs from $run (see $out/metrics.diff): the recording is not the committed run's" >&2
  exit 1
fi
