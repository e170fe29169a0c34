#!/usr/bin/env bash
# The peer's Python environment: OmniSafe 0.5.0 on Safety-Gymnasium 1.0.0, in .deps/omnisafe-venv,
# for tools/peers/omnisafe_saclag.py (OmniSafe's SACLag beside our runs, docs/peers.md). Not part of
# `make test`, and nothing of the project imports it: OmniSafe is a peer to measure against.
#
# Why Python 3.10: safety-gymnasium 1.0.0 pins pygame 2.1.0, which has no wheel for 3.11 or later,
# and omnisafe 0.5.0 pins pandas 2.0.3, which needs numpy < 1.24 to import. The interpreter is
# $PYTHON if set, else pyenv's newest 3.10 (~/.pyenv/versions/3.10.*), else python3.10 on PATH.
#
# PyTorch comes from PyPI, whose Linux wheels bring NVIDIA's CUDA libraries (a few GB) even on a
# machine without a GPU; TORCH_INDEX_URL (e.g. https://download.pytorch.org/whl/cpu) takes the
# CPU-only wheel from that index instead, where it is reachable. TORCH_SPEC pins the version.
#
# Idempotent: a venv that already imports omnisafe 0.5.0 and safety_gymnasium 1.0.0 is left alone.
# Run from anywhere: bash tools/peers/omnisafe-venv.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=.deps/omnisafe-venv

find_python() {
  if [ -n "${PYTHON:-}" ]; then echo "$PYTHON"; return; fi
  local root
  root=$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")
  local best
  best=$(ls -d "$root"/versions/3.10.* 2>/dev/null | sort -V | tail -n 1 || true)
  if [ -n "$best" ] && [ -x "$best/bin/python3.10" ]; then echo "$best/bin/python3.10"; return; fi
  if command -v python3.10 >/dev/null; then command -v python3.10; return; fi
  echo "omnisafe-venv: no Python 3.10 (set PYTHON, or install it: pyenv install 3.10)" >&2
  exit 1
}

ready() {
  [ -x "$VENV/bin/python" ] && "$VENV/bin/python" - <<'EOF' 2>/dev/null
import importlib.metadata as m
assert m.version("omnisafe") == "0.5.0" and m.version("safety-gymnasium") == "1.0.0"
import omnisafe, safety_gymnasium, torch  # noqa: F401  (imports, not only metadata)
EOF
}

if ready; then
  echo "omnisafe-venv: ready at $VENV (already installed)"
  exit 0
fi
PY=$(find_python)
version=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [ "$version" != "3.10" ]; then
  echo "omnisafe-venv: $PY is Python $version; safety-gymnasium 1.0.0 needs 3.10" >&2
  exit 1
fi
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
PIP=("$VENV/bin/python" -m pip install --disable-pip-version-check --progress-bar off)
if [ -n "${TORCH_INDEX_URL:-}" ]; then
  "${PIP[@]}" --index-url "$TORCH_INDEX_URL" "torch${TORCH_SPEC:-}"
elif [ -n "${TORCH_SPEC:-}" ]; then
  "${PIP[@]}" "torch$TORCH_SPEC"
fi
"${PIP[@]}" "numpy<1.24" "safety-gymnasium==1.0.0" "omnisafe==0.5.0"
if ! ready; then
  echo "omnisafe-venv: installed, but omnisafe or safety_gymnasium does not import in $VENV" >&2
  exit 1
fi
echo "omnisafe-venv: ready at $VENV"
