#!/usr/bin/env bash
# `make test-safety-gym` (part of `make test`): the wheel of `make wheel` installed into a venv
# that already holds a safe-RL researcher's stack, safety-gymnasium 1.0.0 on Python 3.10 with
# numpy 1.23.5, gymnasium 0.28.1 and mujoco 2.3.3 (python/requirements-safety-gym.txt), must
# change none of its packages: the versions before and after are compared line by line, and
# `pip check` must be clean. Then python/tests_safety_gym runs there (the wrapper on
# SafetyHopperVelocity-v1, cost-labelled demonstrations on SafetyPointGoal1-v0, the command's
# message about its runtime), and the part of python/tests that needs no Gymnasium >= 1.0 or
# MuJoCo task: the Python API on the oldest numpy and gymnasium the wheel allows.
#
# Python 3.10: safety-gymnasium 1.0.0 pins pygame 2.1.0, which has no wheel for 3.11 or later.
# The interpreter is $PYTHON310 if set, else pyenv's newest 3.10, else python3.10 on the PATH.
# The project's machine image has pyenv's 3.10 (its package list names pip for 3.10); where no
# 3.10 exists the check is skipped with a banner on stderr, not failed: no registry reached
# here serves a CPython to install. DEFENDER_REQUIRE_PY310=1 makes that a failure.
#
# The venv is a temporary folder (about 300 MB, removed after); binary wheels only, nothing may
# compile. Measured on the project's busy 2-core machine: 79 s to install their stack with an
# empty pip cache (27-68 s from it), then about a minute of tests.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
WHEEL=$(ls dist/defender_rl-*.whl)
REQ=python/requirements-safety-gym.txt

find_python310() {
  if [ -n "${PYTHON310:-}" ]; then echo "$PYTHON310"; return; fi
  local root best
  root=$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")
  best=$(ls -d "$root"/versions/3.10.* 2>/dev/null | sort -V | tail -n 1 || true)
  if [ -n "$best" ] && [ -x "$best/bin/python3.10" ]; then echo "$best/bin/python3.10"; return; fi
  command -v python3.10 || true
}

PY=$(find_python310)
if [ -z "$PY" ] || ! "$PY" -c 'import sys, venv; assert sys.version_info[:2] == (3, 10)' 2>/dev/null; then
  {
    echo "################################################################################"
    echo "test-safety-gym: SKIPPED: no Python 3.10 here (PYTHON310, ~/.pyenv/versions/3.10.*,"
    echo "python3.10 on the PATH). The wheel was NOT checked beside safety-gymnasium 1.0.0."
    echo "Install one (pyenv install 3.10) or set PYTHON310 to run it."
    echo "################################################################################"
  } >&2
  [ "${DEFENDER_REQUIRE_PY310:-0}" = 1 ] && exit 1
  exit 0
fi

WORK=$(mktemp -d "${TMPDIR:-/tmp}/defender-safety-gym.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
VPY="$WORK/venv/bin/python"
PIP=("$VPY" -m pip --disable-pip-version-check)

echo "test-safety-gym: $("$PY" --version) venv with $REQ"
start=$(date +%s)
"$PY" -m venv "$WORK/venv"
"${PIP[@]}" install --quiet --only-binary=:all: -r "$REQ"
echo "test-safety-gym: their stack installed in $(( $(date +%s) - start )) s"
"${PIP[@]}" list --format=freeze > "$WORK/before.txt"

echo "test-safety-gym: installing $WHEEL beside it"
"${PIP[@]}" install --quiet --only-binary=:all: "$WHEEL"
"${PIP[@]}" list --format=freeze > "$WORK/after.txt"
# Every package of theirs at the same version; ours the only new line.
changed=$(diff "$WORK/before.txt" "$WORK/after.txt" | grep '^[<>]' | grep -v '^> defender-rl==' || true)
if [ -n "$changed" ]; then
  echo "test-safety-gym: installing the wheel changed their packages (< before, > after):" >&2
  echo "$changed" >&2
  exit 1
fi
for pkg in numpy gymnasium mujoco safety-gymnasium; do
  grep -i "^$pkg==" "$WORK/after.txt" | sed 's/^/test-safety-gym: unchanged: /'
done
"${PIP[@]}" check

mkdir -p "$WORK/run"
cd "$WORK/run"
# Only the tests of python/tests that need neither Gymnasium >= 1.0 nor a MuJoCo task of it
# (Hopper-v5 and the other v5 tasks, gym.make_vec, Minari, Ray, TensorBoard): the API itself.
OLD_STACK_TESTS=(test_demos.py test_demos_cost.py test_step_cost.py test_episode_set.py test_costs.py
  test_cli_launcher.py test_arguments.py test_wrapper.py)
# test_wrapper.py's tests that make Hopper-v5 (Gymnasium >= 1.0), by name.
NOT_V5="not (test_is_a_gymnasium_wrapper_and_passes_check_env"
NOT_V5+=" or test_async_vector_env_pickles_the_arguments or test_demonstrations_that_do_not_fit)"
env -i HOME="$HOME" LANG=C.UTF-8 TMPDIR="${TMPDIR:-/tmp}" PATH="$WORK/venv/bin:/usr/local/bin:/usr/bin:/bin" \
  DEFENDER_SOURCE_TREE="$ROOT" DEFENDER_PROGRESS_INTERVAL=off \
  "$VPY" -m pytest "$ROOT/python/tests_safety_gym" "${OLD_STACK_TESTS[@]/#/$ROOT/python/tests/}" \
  -k "$NOT_V5" -q -rs -p no:cacheprovider
