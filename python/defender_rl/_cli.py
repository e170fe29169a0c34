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

Neither ``mujoco`` nor Gymnasium >= 1.0 is a dependency of the wheel (the wrapper needs neither,
and a safety-gymnasium venv must keep its mujoco 2.3.3 and gymnasium 0.28.1): the extra
``defender-rl[cli]`` pins them, and every error below names it, with a venv of its own where
this one holds another version.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
import platform
import sys
from pathlib import Path

MUJOCO_VERSION = "3.17.0"
_LIB = f"libmujoco.so.{MUJOCO_VERSION}"
_TASK_FILES = ("hopper.xml", "walker2d_v5.xml", "inverted_double_pendulum.xml")
#: How to get what the command needs: the extra pins mujoco==3.17.0 and gymnasium>=1.0.
INSTALL = "pip install 'defender-rl[cli]'"
OWN_VENV = (
    "python -m venv ~/.venvs/defender && ~/.venvs/defender/bin/pip install 'defender-rl[cli]' "
    "(then ~/.venvs/defender/bin/defender)"
)


def _installed_version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def _runtime_version(libs: list[str]) -> str | None:
    """The MuJoCo version of the runtime the package found ships (``libmujoco.so.2.3.3``):
    what the binary would load, whatever the installed metadata says."""
    versions = [name.split("libmujoco.so.", 1)[1] for name in libs if name.startswith("libmujoco.so.")]
    return versions[0] if len(versions) == 1 else None


def _fix(package: str, have: str | None) -> str:
    """How to get the command's runtime when ``package`` is missing or at version ``have``."""
    if have is None:
        return f"install it with the extra that pins it: {INSTALL}"
    return (
        f"this Python has {package} {have}; if its other packages need that version (safety-gymnasium "
        f"1.0.0 pins mujoco 2.3.3 and gymnasium 0.28.1), give the command a venv of its own: {OWN_VENV}; "
        f"otherwise {INSTALL} (it replaces {package} {have})"
    )


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
            "(Rust 1.95, MuJoCo 3.17.0; docs/cli.md)"
        )
    raise LaunchError(
        f"this defender-rl has no defender binary ({exe} is missing): it was built from source, "
        "which builds the Python module only; install the wheel with the command's runtime "
        "(`pip install 'defender-rl[cli]'`, or `make wheel` then "
        "`pip install \"$(ls dist/defender_rl-*.whl)[cli]\"`), or build the command with "
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
            f"the defender command needs MuJoCo {MUJOCO_VERSION}'s runtime from the `mujoco` package "
            f"(mujoco=={MUJOCO_VERSION}), which is not installed for {sys.executable} (the Python "
            f"wrapper needs none); {_fix('mujoco', None)}"
        )
    if not (found / _LIB).is_file():
        have = sorted(p.name for p in found.glob("libmujoco.so*"))
        raise LaunchError(
            f"the defender command needs MuJoCo {MUJOCO_VERSION}'s runtime ({_LIB}); the `mujoco` "
            f"package at {found} has {', '.join(have) or 'no libmujoco.so'}; "
            f"{_fix('mujoco', _runtime_version(have) or _installed_version('mujoco') or 'of another version')}"
        )
    return found


def gym_assets() -> Path:
    """The installed Gymnasium's folder of MuJoCo task files (``envs/mujoco/assets``)."""
    found = _package_dir("gymnasium")
    if found is None:
        raise LaunchError(
            "the defender command reads the task files (hopper.xml, ...) of Gymnasium >= 1.0, which "
            f"is not installed for {sys.executable}; {_fix('gymnasium', None)}"
        )
    assets = found / "envs" / "mujoco" / "assets"
    missing = [f for f in _TASK_FILES if not (assets / f).is_file()]
    if missing:
        raise LaunchError(
            f"the defender command reads the task files of Gymnasium >= 1.0; the gymnasium at {found} "
            f"lacks {', '.join(missing)} (looked in {assets}); "
            f"{_fix('gymnasium', _installed_version('gymnasium') or 'of another version')}"
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
