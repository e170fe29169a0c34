"""The wheel as a user gets it (run by scripts/test-wheel.sh in a fresh venv, from a temporary
folder, with no cargo on the PATH): the ``defender`` command, a short training with DEFENDER,
the Gymnasium wrapper on Hopper-v5, and nothing that reaches for a toolchain or this source tree.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig

import pytest

SOURCE = pathlib.Path(os.environ["DEFENDER_SOURCE_TREE"])
GUARD_LOG = pathlib.Path(os.environ["DEFENDER_GUARD_LOG"])
VENV = pathlib.Path(sys.prefix)


@pytest.fixture(autouse=True)
def no_toolchain_reached():
    yield
    assert not GUARD_LOG.exists(), f"a toolchain was called: {GUARD_LOG.read_text()}"


def defender(*args: str, cwd: pathlib.Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(["defender", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


def test_installed_from_the_wheel_not_the_source_tree():
    import defender_rl
    import defender_rl._core

    assert pathlib.Path(defender_rl.__file__).is_relative_to(VENV), defender_rl.__file__
    assert shutil.which("defender") == str(pathlib.Path(sysconfig.get_path("scripts")) / "defender")
    assert shutil.which("cargo") is None or "guard" in shutil.which("cargo")
    package = pathlib.Path(defender_rl.__file__).parent
    binary = package / "bin" / "defender"
    # One MuJoCo runtime per process: the extension links none (the binary, in its own process,
    # links the mujoco package's).
    assert b"libmujoco" not in pathlib.Path(defender_rl._core.__file__).read_bytes()
    data = binary.read_bytes()
    assert b"libmujoco.so.3.17.0" in data and b"$ORIGIN/../../mujoco" in data
    for path in package.rglob("*"):
        if path.is_file():
            assert str(SOURCE).encode() not in path.read_bytes(), f"{path} names the source tree"
    assert b".deps/" not in data


def test_env_list(tmp_path):
    done = defender("env", "list", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    for env_id in ("Hopper-v5", "Walker2d-v5", "InvertedDoublePendulum-v5"):
        assert env_id in done.stdout


def test_train_500_steps_with_a_strategy(tmp_path):
    demos = tmp_path / "idp-demos.npz"
    shutil.copy(SOURCE / "data" / "demos" / "InvertedDoublePendulum-v5.npz", demos)
    out = tmp_path / "run"
    done = defender(
        "train", "--env", "InvertedDoublePendulum-v5", "--strategy", "MinDemoW5/MinDemoW10",
        "--steps", "500", "--demos", str(demos), "--out", str(out), cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert (out / "summary.json").exists()
    config = (out / "config.toml").read_text()
    assert "MinDemoW5/MinDemoW10" in config and str(SOURCE) not in config
    rows = (out / "metrics.csv").read_text().splitlines()[1:]
    assert 400 < int(rows[-1].split(",")[1]) <= 500  # the last, unfinished episode has no row
    assert any(r.split(",")[4] == "filtered" for r in rows)  # DEFENDER was at work


def test_train_without_demos_names_what_to_give(tmp_path):
    # An installed binary knows no source tree, so no shipped demonstrations: a clear error.
    done = defender("train", "--env", "InvertedDoublePendulum-v5", "--strategy", "MinDemoW5/MinDemoW10",
                    "--steps", "10", "--out", str(tmp_path / "run"), cwd=tmp_path)  # fmt: skip
    assert done.returncode != 0
    assert "--demos" in done.stderr and "DEFENDER_DATA" in done.stderr, done.stderr


def test_missing_or_wrong_mujoco_and_gymnasium_are_named(tmp_path):
    # A `mujoco` without MuJoCo 3.17.0's runtime, and a `gymnasium` without the task files,
    # found first on the path, as another version installed would be.
    shadow = tmp_path / "shadow"
    (shadow / "mujoco").mkdir(parents=True)
    (shadow / "mujoco" / "__init__.py").write_text("")
    (shadow / "mujoco" / "libmujoco.so.3.3.0").write_text("")
    env = dict(os.environ, PYTHONPATH=str(shadow))
    done = defender("env", "list", cwd=tmp_path, env=env)
    assert done.returncode == 2
    assert "libmujoco.so.3.17.0" in done.stderr and "libmujoco.so.3.3.0" in done.stderr, done.stderr
    assert "mujoco 3.3.0" in done.stderr and "defender-rl[cli]" in done.stderr, done.stderr
    shutil.rmtree(shadow / "mujoco")
    # A Gymnasium that works (defender_rl imports it) but has no task files where they belong.
    import gymnasium

    real = pathlib.Path(gymnasium.__file__).parent
    (shadow / "gymnasium").mkdir()
    (shadow / "gymnasium" / "__init__.py").write_text(
        f"__path__ = [{str(real)!r}]\nexec(open({str(real / '__init__.py')!r}).read())\n"
    )
    done = defender("env", "list", cwd=tmp_path, env=env)
    assert done.returncode == 2
    assert "hopper.xml" in done.stderr and "gymnasium" in done.stderr, done.stderr


def test_defender_wrapper_steps_gymnasiums_hopper(tmp_path):
    import gymnasium as gym
    import numpy as np

    from defender_rl import DefenderWrapper

    demos = tmp_path / "hopper-demos.npz"
    shutil.copy(SOURCE / "data" / "demos" / "Hopper-v5.npz", demos)
    env = DefenderWrapper(gym.make("Hopper-v5"), str(demos), "MeanDemoW5/MeanDemoW10", seed=0)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (11,)
    obs, reward, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
    assert np.isfinite(reward) and "defender_filtered" in info
    env.close()
