#!/usr/bin/env bash
# `make test-omnisafe` (not part of `make test`): OmniSafe 0.5.0's SACLag and PPOLag trained on a
# DEFENDER-wrapped Safety-Gymnasium task through OmniSafe's own API (tools/peers/omnisafe_defender_env.py,
# tools/peers/omnisafe_defender.py; docs/peers.md, "OmniSafe's agents on a DEFENDER-wrapped task").
#
# It runs in OmniSafe's venv, .deps/omnisafe-venv (tools/peers/omnisafe-venv.sh makes it: Python 3.10,
# omnisafe 0.5.0, safety-gymnasium 1.0.0, numpy 1.23.5, gymnasium 0.28.1, mujoco 2.3.3 and PyTorch
# with NVIDIA's CUDA libraries from PyPI, about 6 GB: why this is outside `make test`). Into it go
# the wheel of `make wheel` (reinstalled each time: the version stays 0.1.0 while the code moves;
# --no-deps, and `pip check` then confirms the venv already holds what it needs) and
# python/requirements-omnisafe-test.txt (pytest). Every package the venv held before must be there
# after at the same version (only new ones may appear), as `make test-safety-gym` checks beside
# safety-gymnasium alone. Then python/tests_omnisafe runs there.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=.deps/omnisafe-venv
WHEEL=$(ls dist/defender_rl-*.whl)
PIP=("$VENV/bin/python" -m pip --disable-pip-version-check)

bash tools/peers/omnisafe-venv.sh
WORK=$(mktemp -d "${TMPDIR:-/tmp}/defender-omnisafe.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
"${PIP[@]}" list --format=freeze > "$WORK/before.txt"
echo "test-omnisafe: installing $WHEEL and python/requirements-omnisafe-test.txt into $VENV"
"${PIP[@]}" install --quiet --only-binary=:all: --force-reinstall --no-deps "$WHEEL"
"${PIP[@]}" install --quiet --only-binary=:all: -r python/requirements-omnisafe-test.txt
"${PIP[@]}" list --format=freeze > "$WORK/after.txt"
# Lines of before missing from after: a package removed or at another version (defender-rl's own
# line aside, which a reinstall keeps).
changed=$(grep -v -x -F -f "$WORK/after.txt" "$WORK/before.txt" | grep -v '^defender-rl==' || true)
if [ -n "$changed" ]; then
  echo "test-omnisafe: the install changed packages of $VENV (before):" >&2
  echo "$changed" >&2
  exit 1
fi
added=$(grep -v -x -F -f "$WORK/before.txt" "$WORK/after.txt" | tr '\n' ' ' || true)
echo "test-omnisafe: none of the venv's packages changed; new: ${added:-none}"
"${PIP[@]}" check

start=$(date +%s)
DEFENDER_PROGRESS_INTERVAL=off "$VENV/bin/python" -m pytest python/tests_omnisafe -q -rs -p no:cacheprovider
echo "test-omnisafe: python/tests_omnisafe took $(( $(date +%s) - start )) s"
