"""The ``defender`` command of the wheel: finds what the Rust binary needs, then becomes it.

The wheel carries the command line (``defender_rl/bin/defender``, the same binary as
``cargo build -p defender-cli``) and this launcher, installed as the ``defender`` script. The
binary links MuJoCo 3.17.0's runtime, which the ``mujoco`` package ships
(``mujoco/libmujoco.so.3.17.0``), and reads Gymnasium's task files from the installed
``gymnasium`` (``gymnasium/envs/mujoco/assets``). Both are found here with importlib, without
importing them, wherever they are installed; a missing one is named, with the command that
installs it, before the binary starts (a missing shared library would otherwise be the
loader's terse "cannot open shared object file").

The extension module ``defender_rl._core`` links no MuJoCo: a Python process using
Gymnasium's MuJoCo environments keeps one MuJoCo runtime; the binary runs in its own process.
"""

from __future__ import annotations

import importlib.util
import os
import platform
import sys
from pathlib import Path

MUJOCO_VERSION = "3.17.0"
_LIB = f"libmujoco.so.{MUJOCO_VERSION}"
_TASK_FILES = ("hopper.xml", "walker2d_v5.xml", "inverted_double_pendulum.xml")


class LaunchError(RuntimeError):
    """What the ``defender`` command needs and cannot find, with how to get it."""


def binary() -> Path:
    """The ``defender`` binary inside the installed package. Raises :class:`LaunchError` on a
    platform the wheel does not cover, or in a build from source, which has no binary."""
    exe = Path(__file__).resolve().parent / "bin" / "defender"
    if exe.is_file() and os.access(exe, os.X_OK):
        return exe
    here = f"{sys.platform} {platform.machine()}"
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise LaunchError(
            f"the defender command ships in the Linux x86_64 wheel only, and this is {here}; "
            "build it from the repository instead: `cargo install --path crates/defender-cli` "
            "(Rust 1.95, MuJoCo 3.17.0; README, 'The command line')"
        )
    raise LaunchError(
        f"this defender-rl has no defender binary ({exe} is missing): it was built from source, "
        "which builds the Python module only; install the wheel (`pip install defender-rl` or "
        "`make wheel` then `pip install dist/defender_rl-*.whl`), or build the command with "
        "`cargo install --path crates/defender-cli`"
    )


def _package_dir(name: str) -> Path | None:
    # find_spec on a top-level name locates the package without importing it (importing mujoco
    # would load its runtime into this short-lived process for nothing).
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def mujoco_dir() -> Path:
    """The folder of the installed ``mujoco`` package holding ``libmujoco.so.3.17.0``."""
    found = _package_dir("mujoco")
    if found is None:
        raise LaunchError(
            f"defender needs MuJoCo {MUJOCO_VERSION}'s runtime from the `mujoco` package, which is "
            f"not installed for {sys.executable}; install it: pip install mujoco=={MUJOCO_VERSION}"
        )
    if not (found / _LIB).is_file():
        have = sorted(p.name for p in found.glob("libmujoco.so*"))
        raise LaunchError(
            f"defender needs MuJoCo {MUJOCO_VERSION}'s runtime ({_LIB}); the `mujoco` package at "
            f"{found} has {', '.join(have) or 'no libmujoco.so'}; install the right one: "
            f"pip install mujoco=={MUJOCO_VERSION}"
        )
    return found


def gym_assets() -> Path:
    """The installed Gymnasium's folder of MuJoCo task files (``envs/mujoco/assets``)."""
    found = _package_dir("gymnasium")
    if found is None:
        raise LaunchError(
            "defender reads the task files (hopper.xml, ...) of Gymnasium, which is not installed "
            f"for {sys.executable}; install it: pip install 'gymnasium>=1.0'"
        )
    assets = found / "envs" / "mujoco" / "assets"
    missing = [f for f in _TASK_FILES if not (assets / f).is_file()]
    if missing:
        raise LaunchError(
            f"the Gymnasium at {found} lacks the task files {', '.join(missing)} (looked in "
            f"{assets}); install Gymnasium 1.0 or newer: pip install 'gymnasium>=1.0'"
        )
    return assets


def command_env(environ: dict[str, str] | None = None) -> dict[str, str]:
    """The environment the binary runs in: the MuJoCo runtime's folder first on
    LD_LIBRARY_PATH, and DEFENDER_GYM_ASSETS (kept if the caller set it)."""
    env = dict(os.environ if environ is None else environ)
    lib = str(mujoco_dir())
    env["LD_LIBRARY_PATH"] = os.pathsep.join([lib, *filter(None, [env.get("LD_LIBRARY_PATH")])])
    if not env.get("DEFENDER_GYM_ASSETS"):
        env["DEFENDER_GYM_ASSETS"] = str(gym_assets())
    return env


def main() -> None:
    """The ``defender`` script: replaces this process by the binary, with the same arguments
    (signals, exit codes and the terminal go straight to it)."""
    try:
        exe = binary()
        env = command_env()
    except LaunchError as e:
        sys.stderr.write(f"error: {e}\n")
        sys.exit(2)
    os.execve(exe, [str(exe), *sys.argv[1:]], env)


if __name__ == "__main__":
    main()
