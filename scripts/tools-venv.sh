#!/usr/bin/env bash
# The Python environment for the scripts under tools/: it regenerates committed test data
# (Gymnasium rollouts, dtw-python, fastdtw and PyTorch golden values) and runs the side-by-side
# benchmarks (dtaidistance, Stable-Baselines3, SBX). CI does not need it.
# WITH_TORCH=0 skips the RL peers (PyTorch, Stable-Baselines3, JAX, SBX: a large download).
# TORCH_INDEX_URL (e.g. https://download.pytorch.org/whl/cpu) takes PyTorch's CPU-only wheel
# from that index where it is reachable; by default everything comes from PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
VENV=.deps/tools-venv
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
PIP=("$VENV/bin/python" -m pip install --quiet --disable-pip-version-check)
"${PIP[@]}" "numpy>=1.26,<3" "mujoco==3.17.0" "gymnasium[mujoco]==1.4.0" dtw-python dtaidistance \
  "fastdtw==0.3.4"
if [ "${WITH_TORCH:-1}" = 1 ]; then
  if [ -n "${TORCH_INDEX_URL:-}" ]; then
    "${PIP[@]}" --index-url "$TORCH_INDEX_URL" torch
  fi
  # SBX (`sbx-rl`) is Stable-Baselines3's SAC/TD3 on JAX; jax[cpu] keeps it off any GPU.
  "${PIP[@]}" torch stable-baselines3 "jax[cpu]" sbx-rl
fi
echo "tools-venv: ready at $VENV"
