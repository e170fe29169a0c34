#!/usr/bin/env bash
# The main job (`make run`): SAC with and without DEFENDER on one task with the demonstrations
# shipped under data/demos/, side by side (one core each), then the paper's table and the plots.
#
#   make run                                     # InvertedDoublePendulum-v5, 15000 steps, seed 0
#   make run ENV_ID=Hopper-v5 STEPS=50000        # any task with shipped demonstrations
#   make run STRATEGY=MeanBothW5/MeanBothW5 RUN_DIR=runs/other
set -euo pipefail
cd "$(dirname "$0")/.."
RUN_DIR=${1:-runs/main}
ENV_ID=${ENV_ID:-InvertedDoublePendulum-v5}
STEPS=${STEPS:-15000}
SEED=${SEED:-0}
# auto: chosen from the demonstrations before training (`defender select`), as in the runs that
# chose the default profile, keeps-learning (docs/results-keeps-learning.md).
STRATEGY=${STRATEGY:-auto}
EVAL_FREQ=${EVAL_FREQ:-2500}

echo "== building defender (release) =="
cargo build --release -p defender-cli
BIN=target/release/defender

if [ -e "$RUN_DIR" ]; then
  echo "== replacing the previous $RUN_DIR =="
  rm -rf "$RUN_DIR"
fi
mkdir -p "$RUN_DIR"
echo "== training SAC on $ENV_ID for $STEPS steps: bare, and with DEFENDER $STRATEGY (in parallel) =="
# One network thread per run: two runs use the two cores without contending (docs/architecture.md, "One run, one core").
export DEFENDER_NN_THREADS=1
common=(--env "$ENV_ID" --algo sac --steps "$STEPS" --seed "$SEED" --eval-freq "$EVAL_FREQ")
# Both runs print to this terminal: each line of their stderr (progress, warnings) is labelled.
"$BIN" train "${common[@]}" --out "$RUN_DIR/sac-bare-s$SEED" 2> >(sed -u 's/^/[bare] /' >&2) &
bare=$!
"$BIN" train "${common[@]}" --strategy "$STRATEGY" --out "$RUN_DIR/sac-defender-s$SEED" \
  2> >(sed -u 's/^/[defender] /' >&2) &
defended=$!
wait "$bare"
wait "$defended"

echo
echo "== report (also in $RUN_DIR/report.md; plots in $RUN_DIR/plots) =="
"$BIN" report "$RUN_DIR" --plots "$RUN_DIR/plots" --out "$RUN_DIR/report.md"
cat "$RUN_DIR/report.md"
echo
ls "$RUN_DIR/plots"
