#!/usr/bin/env bash
# The episode sets of docs/results-navigation.md, for one task, remade bit for bit (they are too
# large for git: 11-21 MB each on the Car; .gitignore: results/**/*.npz):
#
#   ppolag-s0/episodes.npz   seed 0's recorded training episodes (the demonstrations' learner)
#   ppolag-s1/episodes.npz   seed 1's, the held-out episodes the screens replay
#   demos.npz                the demonstrations, from seed 0's policy snapshots
#
# Steps 1 and 2 of tools/navigation/navigation-screen.sh: OmniSafe's PPOLag, seeds 0 and 1,
# STEPS steps each (tools/navigation/navigation_train.py), then PER_SNAPSHOT episodes of each
# snapshot's deterministic policy, N_SAFE + N_UNSAFE kept (tools/navigation/navigation_demos.py).
#
# Bit for bit: one thread, and the arithmetic pinned to what does not depend on the CPU's vector
# width (MKL_CBWR=COMPATIBLE,STRICT: MKL's reproducible code path; ATEN_CPU_CAPABILITY=default:
# PyTorch's unvectorised kernels). Without them the run follows the CPU: on the same versions, MKL's
# AVX-512 and AVX2 paths give another first episode, and the learner drifts from there.
#
# The sets' SHA-256 are committed in results/navigation/TASK/episode-sets.sha256. With it there,
# the sets are made in DIR (default: a new temporary folder), checked against it (exit 1 naming
# the set that differs), and only then copied into results/navigation/TASK/. Without it (the first
# making) they are made in place, in results/navigation/TASK/ (the run folders' CSV files are
# committed), and the file is written.
#
#   bash tools/navigation/navigation-sets.sh SafetyCarGoal1-v0            # about 40 minutes on 2 busy cores
#   bash tools/navigation/navigation-sets.sh SafetyCarGoal1-v0 /tmp/car   # resumable in /tmp/car
#
# Needs tools/peers/omnisafe-venv.sh's venv with the wheel installed (PY to use another python).
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
TASK=${1:?usage: navigation-sets.sh TASK [DIR]}
STEPS=${STEPS:-100000}
PER_SNAPSHOT=${PER_SNAPSHOT:-20}
N_SAFE=${N_SAFE:-25}
N_UNSAFE=${N_UNSAFE:-25}
PY=${PY:-.deps/omnisafe-venv/bin/python}
OUT=results/navigation/$TASK
MANIFEST=$OUT/episode-sets.sha256
SETS=(ppolag-s0/episodes.npz ppolag-s1/episodes.npz demos.npz)
RUN=(env OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 MKL_CBWR=COMPATIBLE,STRICT ATEN_CPU_CAPABILITY=default nice -n 10)

# The episode sets are saved by defender_rl (navigation_episodes.py) once training ends: check
# for it now, not after 20 minutes of training.
if ! "$PY" -c "import defender_rl, omnisafe" 2>/dev/null; then
  echo "navigation-sets: $PY cannot import defender_rl and omnisafe; make the venv and install the" >&2
  echo "  wheel into it: bash tools/peers/omnisafe-venv.sh && make wheel && $PY -m pip install" >&2
  echo "  --no-deps --force-reinstall dist/defender_rl-*.whl (as scripts/test-omnisafe.sh does)" >&2
  exit 2
fi

if [ -f "$MANIFEST" ]; then
  DIR=${2:-$(mktemp -d "${TMPDIR:-/tmp}/navigation-sets.XXXXXX")}
else
  DIR=${2:-$OUT}
fi
mkdir -p "$DIR"
echo "navigation-sets: $TASK into $DIR"

for seed in 0 1; do
  if [ ! -f "$DIR/ppolag-s$seed/episodes.npz" ]; then
    rm -rf "$DIR/ppolag-s$seed"
    "${RUN[@]}" "$PY" tools/navigation/navigation_train.py --env "$TASK" --seed "$seed" --steps "$STEPS" \
      --out "$DIR/ppolag-s$seed"
  fi
done
if [ ! -f "$DIR/demos.npz" ]; then
  "${RUN[@]}" "$PY" tools/navigation/navigation_demos.py --run "$DIR/ppolag-s0" --per-snapshot "$PER_SNAPSHOT" \
    --safe "$N_SAFE" --unsafe "$N_UNSAFE" --seed 0 --out "$DIR/demos.npz" --candidates "$DIR/demo-candidates.csv"
fi

if [ ! -f "$MANIFEST" ]; then
  if [ "$(cd "$DIR" && pwd -P)" != "$(cd "$OUT" && pwd -P)" ]; then
    echo "navigation-sets: no $MANIFEST yet: the first making is in place (leave DIR out)" >&2
    exit 2
  fi
  (cd "$OUT" && sha256sum "${SETS[@]}") > "$MANIFEST"
  echo "navigation-sets: wrote $MANIFEST"
  cat "$MANIFEST"
  exit 0
fi

if ! (cd "$DIR" && sha256sum --check --strict "$ROOT/$MANIFEST"); then
  echo "navigation-sets: the sets made in $DIR differ from $MANIFEST (kept there; nothing copied)" >&2
  for f in ppolag-s0/labels.csv ppolag-s1/labels.csv demo-candidates.csv; do
    cmp -s "$DIR/$f" "$OUT/$f" && echo "  $f: the same as the committed one" >&2 || echo "  $f: differs" >&2
  done
  exit 1
fi
for f in "${SETS[@]}"; do
  [ "$DIR/$f" -ef "$OUT/$f" ] || cp "$DIR/$f" "$OUT/$f"
done
echo "navigation-sets: $TASK: the sets are the committed ones, bit for bit; in $OUT"
