#!/usr/bin/env bash
# `make test-wheel` (part of `make test`): the wheel of `make wheel` as a user gets it. A new venv
# (a temporary folder, removed after) installs only dist/defender_rl-*.whl with its
# dependencies, binary wheels only (--only-binary: nothing may compile), plus the test tools;
# then python/tests_wheel runs from a temporary folder with a PATH that has no cargo: a `cargo`,
# `rustc`, `rustup` or `maturin` there is a guard that records the call and fails, and the tests
# check that no file of the install names this source tree.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
WHEEL=$(ls dist/defender_rl-*.whl)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/defender-wheel-test.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
PY=$(command -v "${PYTHON:-python3}")
PY=$("$PY" -c 'import sys; print(sys.executable)')  # the interpreter itself, not a pyenv shim

mkdir -p "$WORK/guard" "$WORK/run"
for tool in cargo rustc rustup maturin; do
  printf '#!/bin/sh\necho "%s $*" >> "%s/guard.log"\necho "toolchain reached: %s" >&2\nexit 97\n' \
    "$tool" "$WORK" "$tool" > "$WORK/guard/$tool"
  chmod +x "$WORK/guard/$tool"
done

echo "test-wheel: a fresh venv with $WHEEL"
start=$(date +%s)
"$PY" -m venv "$WORK/venv"
"$WORK/venv/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
  "$WHEEL[cli,mujoco]" -r python/requirements-wheel-test.txt
echo "test-wheel: installed in $(( $(date +%s) - start )) s"

cd "$WORK/run"
env -i HOME="$HOME" LANG=C.UTF-8 TMPDIR="${TMPDIR:-/tmp}" \
  PATH="$WORK/venv/bin:$WORK/guard:/usr/local/bin:/usr/bin:/bin" \
  DEFENDER_SOURCE_TREE="$ROOT" DEFENDER_GUARD_LOG="$WORK/guard.log" \
  "$WORK/venv/bin/python" -m pytest "$ROOT/python/tests_wheel" -q -p no:cacheprovider
