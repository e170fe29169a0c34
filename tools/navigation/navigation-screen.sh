#!/usr/bin/env bash
# The navigation tasks' first look (docs/results-navigation.md), for one task:
#
#   1-2. the episode sets (tools/navigation/navigation-sets.sh, when they are not there): OmniSafe's
#      PPOLag, bare, seeds 0 and 1, STEPS steps each, every training episode recorded and
#      labelled by docs/SPEC.md section 13 (limit 25), a policy snapshot every epoch; then
#      PER_SNAPSHOT episodes of each of seed 0's snapshots' deterministic policy through
#      defender_rl.DemoRecorder(episode_cost_limit=25), N_SAFE + N_UNSAFE kept at evenly spaced
#      positions. Made bit for bit and checked against results/navigation/TASK/episode-sets.sha256;
#   3. the strategy `auto` picks on them (`defender select --scaling auto --no-equal`, as
#      `defender train --strategy auto` chooses);
#   4. the offline screen: seed 1's recorded training episodes replayed in order through that
#      strategy, plain and z-scored, with SPEC's filter, own episodes 50 and the default
#      (margin 0.02 + own 50) (`defender screen`);
#   5. the diagnostic (docs/results-navigation.md, "Why"): steps 3 and 4 again on copies of both
#      sets whose observation is only the hazards lidar (16 features), and only its largest bin
#      (1 feature: the nearness of the closest hazard), into OUT/features/
#      (tools/navigation/navigation_features.py; the columns from navigation_layout.py, which
#      checks them against the task);
#   6. the classifier trigger (SPEC section 15) on the same demonstrations and held-out episodes,
#      its setting chosen by cross-validation on the demonstrations (tools/navigation/navigation_classifier.py);
#   7. the figures the page quotes beside the screens (tools/navigation/navigation_summary.py -> summary.json).
#
# Every step is deterministic given the seeds and skipped when its output exists, so the script
# resumes. The .npz files and OmniSafe's snapshots stay out of git (.gitignore: results/**/*.npz,
# results/**/torch_save/); navigation-sets.sh remakes the sets.
#
#   bash tools/navigation/navigation-screen.sh SafetyPointGoal1-v0
#   STEPS=100000 PER_SNAPSHOT=20 bash tools/navigation/navigation-screen.sh SafetyCarGoal1-v0
#
# Needs tools/peers/omnisafe-venv.sh's venv with the wheel installed and target/release/defender
# (cargo build --release -p defender-cli). Runs one process at a time, niced, one thread.
set -euo pipefail
cd "$(dirname "$0")/../.."
TASK=${1:?usage: navigation-screen.sh TASK (SafetyPointGoal1-v0 or SafetyCarGoal1-v0)}
STEPS=${STEPS:-100000}
PER_SNAPSHOT=${PER_SNAPSHOT:-20}
N_SAFE=${N_SAFE:-25}
N_UNSAFE=${N_UNSAFE:-25}
PY=${PY:-.deps/omnisafe-venv/bin/python}
DEFENDER=${DEFENDER:-target/release/defender}
OUT=results/navigation/$TASK
RUN=(env OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 MKL_CBWR=COMPATIBLE,STRICT ATEN_CPU_CAPABILITY=default nice -n 10)
mkdir -p "$OUT"

DEMOS=$OUT/demos.npz
for f in ppolag-s0/episodes.npz ppolag-s1/episodes.npz demos.npz; do
  if [ ! -f "$OUT/$f" ]; then
    STEPS=$STEPS PER_SNAPSHOT=$PER_SNAPSHOT N_SAFE=$N_SAFE N_UNSAFE=$N_UNSAFE PY=$PY \
      bash tools/navigation/navigation-sets.sh "$TASK"
    break
  fi
done

if [ ! -f "$OUT/selection.csv" ]; then
  "${RUN[@]}" "$DEFENDER" select --demos "$DEMOS" --no-equal --scaling auto --out "$OUT/selection.csv"
fi
# The first row is auto's choice (docs/cli.md); its strategy is the CSV's second column.
STRATEGY=$(awk -F, 'NR == 2 { print $2 }' "$OUT/selection.csv")

if [ ! -f "$OUT/screen.csv" ]; then
  "${RUN[@]}" "$DEFENDER" screen --demos "$DEMOS" --episodes "$OUT/ppolag-s1/episodes.npz" \
    --strategy "$STRATEGY" --scaling none --scaling zscore \
    --variant '' --variant 'own_episodes = { keep = 50 }' --variant $'margin = 0.02\nown_episodes = { keep = 50 }' \
    --out "$OUT/screen.csv"
fi
echo "navigation-screen: $TASK: auto's strategy $STRATEGY; $OUT/screen.csv"

# The hazards lidar's columns: navigation_layout.py's, checked against the task made here.
HAZARDS=$("$PY" tools/navigation/navigation_layout.py "$TASK" hazards_lidar)
FEAT=$OUT/features
mkdir -p "$FEAT"
for kind in hlidar hmax; do
  opt=(--columns "$HAZARDS")
  [ "$kind" = hmax ] && opt=(--max-of "$HAZARDS")
  # The copies are .npz (not committed); the CSV files are.
  for part in demos ppolag-s1/episodes; do
    name=$(basename "$part")
    [ -f "$FEAT/$kind-$name.npz" ] ||
      "${RUN[@]}" "$PY" tools/navigation/navigation_features.py "${opt[@]}" --in "$OUT/$part.npz" --out "$FEAT/$kind-$name.npz"
  done
  [ -f "$FEAT/$kind-selection.csv" ] ||
    "${RUN[@]}" "$DEFENDER" select --demos "$FEAT/$kind-demos.npz" --no-equal --scaling auto --out "$FEAT/$kind-selection.csv"
  chosen=$(awk -F, 'NR == 2 { print $2 }' "$FEAT/$kind-selection.csv")
  [ -f "$FEAT/$kind-screen.csv" ] ||
    "${RUN[@]}" "$DEFENDER" screen --demos "$FEAT/$kind-demos.npz" --episodes "$FEAT/$kind-episodes.npz" \
      --strategy "$chosen" --scaling none --scaling zscore \
      --variant '' --variant 'own_episodes = { keep = 50 }' --variant $'margin = 0.02\nown_episodes = { keep = 50 }' \
      --out "$FEAT/$kind-screen.csv"
done

[ -f "$OUT/classifier.json" ] ||
  "${RUN[@]}" "$PY" tools/navigation/navigation_classifier.py --demos "$DEMOS" --episodes "$OUT/ppolag-s1/episodes.npz" \
    --out "$OUT/classifier.json" --csv "$OUT/classifier.csv"

"${RUN[@]}" "$PY" tools/navigation/navigation_summary.py --task-dir "$OUT" --out "$OUT/summary.json"
