#!/usr/bin/env bash
# `make python`: build the defender-rl wheel (crates/defender-py + python/defender_rl, by maturin)
# and install it into the project's venv .deps/venv, with the pinned tools of the Python tests
# (python/requirements-test.txt: maturin, pytest, gymnasium, mujoco, minari). Idempotent: the
# requirements are installed once per change of that file; the wheel is rebuilt every time
# (cargo makes that quick when nothing changed).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=.deps/venv
PY="$VENV/bin/python"
PIP=("$PY" -m pip --disable-pip-version-check)
REQ=python/requirements-test.txt
STAMP="$VENV/.requirements-test.sha256"

want=$(sha256sum "$REQ" | cut -d' ' -f1)
if [ ! -e "$STAMP" ] || [ "$(cat "$STAMP")" != "$want" ]; then
  echo "python: installing $REQ into $VENV"
  "${PIP[@]}" install --quiet -r "$REQ"
  echo "$want" > "$STAMP"
fi

OUT=target/python-wheel
rm -rf "$OUT"
echo "python: building the defender-rl wheel (maturin, release)"
"$VENV/bin/maturin" build --release --quiet --out "$OUT" --interpreter "$PY"
"${PIP[@]}" install --quiet --force-reinstall --no-deps "$OUT"/defender_rl-*.whl
"$PY" -c "import defender_rl; print('python: defender_rl', defender_rl.__version__, 'installed in $VENV')"
