#!/usr/bin/env bash
# One-time, idempotent setup: fetch the MuJoCo runtime and Gymnasium's task files from PyPI
# into .deps/ (ignored by git), and a small Python venv with numpy for the interop tests.
#
#   .deps/mujoco/lib/libmujoco.so.3.17.0 (+ libmujoco.so link)  <- mujoco==3.17.0 wheel
#   .deps/gymnasium/assets/*.xml                                 <- gymnasium==1.4.0 wheel
#   .deps/venv                                                   <- numpy
#
# A user with MuJoCo 3.17.0 installed elsewhere may set MUJOCO_DYNAMIC_LINK_DIR to the folder
# holding libmujoco.so; the runtime is then not extracted.
set -euo pipefail
cd "$(dirname "$0")/.."
DEPS=.deps
MUJOCO_VERSION=3.17.0
GYMNASIUM_VERSION=1.4.0
PY=${PYTHON:-python3}

mkdir -p "$DEPS/wheels"
have_wheel() { compgen -G "$DEPS/wheels/$1-*.whl" >/dev/null; }
if ! have_wheel "mujoco-$MUJOCO_VERSION" || ! have_wheel "gymnasium-$GYMNASIUM_VERSION"; then
  echo "setup: downloading mujoco==$MUJOCO_VERSION and gymnasium==$GYMNASIUM_VERSION wheels"
  "$PY" -m pip download --quiet --no-deps --only-binary=:all: -d "$DEPS/wheels" \
    "mujoco==$MUJOCO_VERSION" "gymnasium==$GYMNASIUM_VERSION"
fi

if [ ! -e "$DEPS/mujoco/lib/libmujoco.so" ]; then
  echo "setup: extracting libmujoco.so.$MUJOCO_VERSION"
  mkdir -p "$DEPS/mujoco/lib"
  "$PY" - "$DEPS" "$MUJOCO_VERSION" <<'PYEOF'
import glob, os, sys, zipfile
deps, version = sys.argv[1], sys.argv[2]
wheel = glob.glob(f"{deps}/wheels/mujoco-{version}-*.whl")[0]
name = f"libmujoco.so.{version}"
with zipfile.ZipFile(wheel) as z, open(f"{deps}/mujoco/lib/{name}.part", "wb") as out:
    out.write(z.read(f"mujoco/{name}"))
os.replace(f"{deps}/mujoco/lib/{name}.part", f"{deps}/mujoco/lib/{name}")
PYEOF
  ln -sf "libmujoco.so.$MUJOCO_VERSION" "$DEPS/mujoco/lib/libmujoco.so"
fi

if [ ! -e "$DEPS/gymnasium/assets/.done" ]; then
  echo "setup: extracting Gymnasium $GYMNASIUM_VERSION task files"
  mkdir -p "$DEPS/gymnasium/assets"
  "$PY" - "$DEPS" "$GYMNASIUM_VERSION" <<'PYEOF'
import glob, os, sys, zipfile
deps, version = sys.argv[1], sys.argv[2]
wheel = glob.glob(f"{deps}/wheels/gymnasium-{version}-*.whl")[0]
prefix = "gymnasium/envs/mujoco/assets/"
with zipfile.ZipFile(wheel) as z:
    for member in z.namelist():
        if member.startswith(prefix) and member.endswith(".xml"):
            with open(f"{deps}/gymnasium/assets/{member[len(prefix):]}", "wb") as out:
                out.write(z.read(member))
PYEOF
  touch "$DEPS/gymnasium/assets/.done"
fi

if [ ! -x "$DEPS/venv/bin/python" ] || ! "$DEPS/venv/bin/python" -c "import numpy" 2>/dev/null; then
  echo "setup: creating .deps/venv with numpy"
  "$PY" -m venv "$DEPS/venv"
  "$DEPS/venv/bin/python" -m pip install --quiet --disable-pip-version-check "numpy>=1.26,<3"
fi
