#!/usr/bin/env bash
# `make wheel`: the defender-rl wheel a user installs without Rust, and its sdist, into dist/.
#
#   dist/defender_rl-<version>-cp310-abi3-manylinux_2_17_x86_64.whl
#       defender_rl/_core.abi3.so   the extension (PyO3, abi3: one wheel for CPython >= 3.10)
#       defender_rl/bin/defender    the command line, run by the `defender` script
#                                   (python/defender_rl/_cli.py finds MuJoCo and Gymnasium)
#   dist/defender_rl-<version>.tar.gz   the sdist (builds the extension; needs Rust)
#
# Both Rust artefacts are linked by zig (the `ziglang` wheel) against glibc 2.17, the floor of
# manylinux2014, and stripped; `auditwheel show` must confirm the tag. The tools are pinned in
# python/requirements-wheel.txt and installed into .deps/wheel-venv: nothing by hand.
# Reproducible: file times come from the last commit (SOURCE_DATE_EPOCH) and the build paths
# are remapped out of the binaries, so two clean clones build the same bytes.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=.deps/wheel-venv
REQ=python/requirements-wheel.txt
STAMP="$VENV/.requirements.sha256"
TARGET=x86_64-unknown-linux-gnu
GLIBC=2.17

want=$(sha256sum "$REQ" | cut -d' ' -f1)
if [ ! -e "$STAMP" ] || [ "$(cat "$STAMP")" != "$want" ]; then
  echo "wheel: installing $REQ into $VENV"
  "${PYTHON:-python3}" -m venv "$VENV"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$REQ"
  echo "$want" > "$STAMP"
fi

# The venv first on the PATH: cargo-zigbuild and maturin find zig through its python.
export PATH="$ROOT/$VENV/bin:$PATH"
# Target folders of their own: a different linker and profile, kept apart from target/release;
# and one per tool, as cargo-zigbuild's and maturin's zig wrappers differ and would otherwise
# rebuild each other's build scripts, and so everything after them, on every `make wheel`.
WHEEL_TARGET="$ROOT/target/wheel"
export CARGO_INCREMENTAL=0
export CARGO_PROFILE_RELEASE_DEBUG=false
export CARGO_PROFILE_RELEASE_STRIP=symbols
# Nothing of this machine in the shipped files: no rpath to .deps/ (the installed `mujoco`
# package beside defender_rl instead), no build-time folder of task files or demonstrations.
export DEFENDER_RPATH="\$ORIGIN/../../mujoco"
export DEFENDER_GYM_ASSETS=""
export DEFENDER_SHIPPED_DATA=""
CARGO_HOME_DIR=${CARGO_HOME:-$HOME/.cargo}
export RUSTFLAGS="--remap-path-prefix=$ROOT=defender --remap-path-prefix=$CARGO_HOME_DIR=cargo"
SOURCE_DATE_EPOCH=$(git log -1 --format=%ct 2>/dev/null || echo 315532800)
export SOURCE_DATE_EPOCH

mkdir -p dist
rm -f dist/defender_rl-*.whl dist/defender_rl-*.tar.gz
echo "wheel: the sdist"
maturin sdist --out dist

echo "wheel: building the defender binary for $TARGET, glibc $GLIBC (zig)"
CARGO_TARGET_DIR="$WHEEL_TARGET/cli" cargo zigbuild --quiet --release -p defender-cli --target "$TARGET.$GLIBC"
BIN=python/defender_rl/bin
trap 'rm -rf "$BIN"' EXIT
mkdir -p "$BIN"
cp "$WHEEL_TARGET/cli/$TARGET/release/defender" "$BIN/defender"
# The file's time goes into the wheel's zip: the commit's, not the build's.
touch -d "@$SOURCE_DATE_EPOCH" "$BIN/defender"

echo "wheel: building the wheel (maturin, zig, manylinux2014)"
CARGO_TARGET_DIR="$WHEEL_TARGET/py" maturin build --quiet --release --strip --zig --compatibility manylinux2014 \
  --target "$TARGET" --out dist
rm -rf "$BIN"

WHEEL=$(ls dist/defender_rl-*.whl)
echo "wheel: checking its tag (auditwheel show)"
show=$(auditwheel show "$WHEEL" 2>&1) || { echo "$show" >&2; exit 1; }
if ! grep -q 'manylinux_2_17_x86_64' <<<"$show"; then
  echo "$show" >&2
  echo "wheel: auditwheel does not accept manylinux_2_17_x86_64 for $WHEEL" >&2
  exit 1
fi
ls -l dist/
sha256sum dist/defender_rl-*
