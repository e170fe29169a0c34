#!/usr/bin/env bash
# The navigation tasks' first look (docs/results-navigation.md), for one task:
#
#   1. OmniSafe's PPOLag, bare, seeds 0 and 1, STEPS steps each, every training episode recorded
#      and labelled by docs/SPEC.md section 13 (limit 25), a policy snapshot every epoch
#      (tools/navigation/navigation_train.py);
#   2. demonstrations from seed 0's snapshots: PER_SNAPSHOT episodes of each snapshot's
#      deterministic policy through defender_rl.DemoRecorder(episode_cost_limit=25), N_SAFE + N_UNSAFE
#      kept at evenly spaced positions (tools/navigation/navigation_demos.py);
#   3. the strategy `auto` picks on them (`defender select --scaling auto --no-equal`, as
#      `defender train --strategy auto` chooses);
#   4. the offline screen: seed 1's recorded training episodes replayed in order through that
#      strategy, plain and z-scored, with SPEC's filter, own episodes 50 and the default
#      (margin 0.02 + own 50) (`defender screen`);
#   5. the diagnostic (docs/results-navigation.md, "Why"): steps 3 and 4 again on copies of both
#      sets whose observation is only the hazards lidar (16 features), and only its largest bin
#      (1 feature: the nearness of the closest hazard), into OUT/features/
#      (tools/navigation/navigation_features.py);
#   6. the figures the page quotes beside the screens (tools/navigation/navigation_summary.py -> summary.json).
#
# Every step is deterministic given the seeds (one torch thread; OmniSafe seeds torch and the task's
# first reset, DemoRecorder resets every episode with its derived seed) and skipped when its output
# exists, so the script resumes. The .npz files and OmniSafe's snapshots stay out of git
# (.gitignore: results/**/*.npz, results/**/torch_save/); this script remakes them.
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
RUN=(env OMP_NUM_THREADS=1 nice -n 10)
mkdir -p "$OUT"

for seed in 0 1; do
  if [ ! -f "$OUT/ppolag-s$seed/episodes.npz" ]; then
    rm -rf "$OUT/ppolag-s$seed"
    "${RUN[@]}" "$PY" tools/navigation/navigation_train.py --env "$TASK" --seed "$seed" --steps "$STEPS" --out "$OUT/ppolag-s$seed"
  fi
done

DEMOS=$OUT/demos.npz
if [ ! -f "$DEMOS" ]; then
  "${RUN[@]}" "$PY" tools/navigation/navigation_demos.py --run "$OUT/ppolag-s0" --per-snapshot "$PER_SNAPSHOT" \
    --safe "$N_SAFE" --unsafe "$N_UNSAFE" --seed 0 --out "$DEMOS" --candidates "$OUT/demo-candidates.csv"
fi

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

# The hazards lidar's columns (Safety-Gymnasium's obs_space_dict order).
case "$TASK" in
  SafetyPointGoal1-v0) HAZARDS=28:44 ;;
  SafetyCarGoal1-v0) HAZARDS=34:50 ;;
  *) echo "navigation-screen: no hazards columns known for $TASK" >&2; exit 2 ;;
esac
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

"${RUN[@]}" "$PY" tools/navigation/navigation_summary.py --task-dir "$OUT" --hazards "$HAZARDS" --out "$OUT/summary.json"
