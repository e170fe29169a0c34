"""The ``defender`` launcher's word when the command's runtime is not there: the wheel
no longer depends on mujoco, so a venv may have none, or safety-gymnasium's 2.3.3, or a Gymnasium
without the v5 task files; each message names ``defender-rl[cli]``, and a venv of its own where
another version is installed. The fresh-venv tests run the real script (python/tests_wheel,
python/tests_safety_gym); here the folders the launcher finds are stand-ins."""

from __future__ import annotations

import pytest

from defender_rl import _cli
from defender_rl._cli import LaunchError


def fake_package(tmp_path, name: str, files=()):
    folder = tmp_path / name
    folder.mkdir()
    for f in files:
        (folder / f).write_text("")
    return folder


def test_no_mujoco_names_the_extra(monkeypatch):
    monkeypatch.setattr(_cli, "_package_dir", lambda name: None)
    with pytest.raises(LaunchError) as caught:
        _cli.mujoco_dir()
    msg = str(caught.value)
    assert "mujoco==3.17.0" in msg and "pip install 'defender-rl[cli]'" in msg and "wrapper needs none" in msg


def test_safety_gymnasiums_mujoco_names_a_venv_of_its_own(tmp_path, monkeypatch):
    folder = fake_package(tmp_path, "mujoco", ["libmujoco.so.2.3.3"])
    monkeypatch.setattr(_cli, "_package_dir", lambda name: folder)
    with pytest.raises(LaunchError) as caught:
        _cli.mujoco_dir()
    msg = str(caught.value)
    assert "libmujoco.so.3.17.0" in msg and "libmujoco.so.2.3.3" in msg and "mujoco 2.3.3" in msg
    assert "venv of its own" in msg and "~/.venvs/defender/bin/pip install 'defender-rl[cli]'" in msg


def test_the_right_runtime_is_found(tmp_path, monkeypatch):
    folder = fake_package(tmp_path, "mujoco", ["libmujoco.so.3.17.0"])
    monkeypatch.setattr(_cli, "_package_dir", lambda name: folder)
    assert _cli.mujoco_dir() == folder


def test_a_gymnasium_without_the_v5_task_files_names_the_extra(tmp_path, monkeypatch):
    gym_dir = fake_package(tmp_path, "gymnasium")
    (gym_dir / "envs" / "mujoco" / "assets").mkdir(parents=True)
    (gym_dir / "envs" / "mujoco" / "assets" / "hopper.xml").write_text("")  # 0.28 has no walker2d_v5.xml
    monkeypatch.setattr(_cli, "_package_dir", lambda name: gym_dir)
    monkeypatch.setattr(_cli, "_installed_version", lambda dist: "0.28.1")
    with pytest.raises(LaunchError) as caught:
        _cli.gym_assets()
    msg = str(caught.value)
    assert "walker2d_v5.xml" in msg and "gymnasium 0.28.1" in msg and "defender-rl[cli]" in msg
    monkeypatch.setattr(_cli, "_package_dir", lambda name: None)
    with pytest.raises(LaunchError, match=r"Gymnasium >= 1\.0.*defender-rl\[cli\]"):
        _cli.gym_assets()
