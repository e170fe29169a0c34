#!/usr/bin/env bash
# The Python environment for the scripts under tools/: it regenerates committed test data
# (Gymnasium rollouts, dtw-python and PyTorch golden values) and runs the side-by-side
# benchmarks (dtaidistance, Stable-Baselines3). CI does not need it.
# WITH_TORCH=0 skips PyTorch and Stable-Baselines3 (a large download).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
VENV=.deps/tools-venv
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
PIP=("$VENV/bin/python" -m pip install --quiet --disable-pip-version-check)
"${PIP[@]}" "numpy>=1.26,<3" "mujoco==3.17.0" "gymnasium[mujoco]==1.4.0" dtw-python dtaidistance
if [ "${WITH_TORCH:-1}" = 1 ]; then
  "${PIP[@]}" torch stable-baselines3
fi
echo "tools-venv: ready at $VENV"
