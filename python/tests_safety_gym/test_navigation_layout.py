"""The navigation tools' observation columns against Safety-Gymnasium 1.0.0 itself: for every
navigation task the tools support (tools/navigation/navigation_layout.py's TASKS, the choices of
navigation_train.py), the task made with `safety_gymnasium.make` has the layout the tools assume
(its `obs_space_dict`'s keys in order, with their sizes), every column range the tools take is the
named entry of the task's own unflattened observation, and the state rule's threshold (the largest
hazards-lidar bin above 1 - 0.2 / 3) is the step after a cost: a robot driven into a hazard pays
on the steps whose next observation crosses it (up to a step at the hazard's edge). Seconds: a few hundred steps per task.

Runs beside safety-gymnasium (scripts/test-beside-safety-gym.sh, in `make test`) and in OmniSafe's
venv (`.deps/omnisafe-venv/bin/python -m pytest python/tests_safety_gym/test_navigation_layout.py`);
it needs neither defender_rl nor OmniSafe.
"""

from __future__ import annotations

import ast
import os
import pathlib
import re
import sys

import numpy as np
import pytest

SOURCE = pathlib.Path(os.environ.get("DEFENDER_SOURCE_TREE", pathlib.Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(SOURCE / "tools" / "navigation"))
import navigation_layout as nl  # noqa: E402

ENTRIES = ("goal_lidar", "hazards_lidar", "vases_lidar")


@pytest.fixture(scope="module", params=nl.TASKS)
def made(request):
    env = nl.make(request.param)
    yield request.param, env
    env.close()


def drive_into_hazard(task_id: str, env, steps: int = 400):
    """Steps toward the nearest hazard from a seeded reset; returns the observations s_0..s_n and
    the costs c_0..c_{n-1} (c_t: the step from s_t to s_{t+1}), stopping 5 steps after the first
    cost."""
    task = env.unwrapped.task
    obs, _ = env.reset(seed=3)
    target = np.asarray(min(task.hazards.pos, key=lambda p: task.agent.dist_xy(np.asarray(p[:2])))[:2])
    seen, costs, first = [obs], [], None
    for t in range(steps):
        x, y = task._ego_xy(target)
        if task_id.startswith("SafetyPoint"):  # forward, turn
            action = np.clip(5 * np.array([x, y]), -1, 1)
        else:  # the car's two wheels
            angle = np.arctan2(y, x)
            forward, turn = (1.0 if abs(angle) < 0.5 else 0.0), -np.clip(2 * angle, -1, 1)
            action = np.clip(np.array([forward - turn, forward + turn]), -1, 1)
        obs, _, cost, _, _, _ = env.step(action)
        seen.append(obs)
        costs.append(float(cost))
        if cost > 0 and first is None:
            first = t
        if first is not None and t >= first + 5:
            break
    return np.asarray(seen), np.asarray(costs)


def test_the_tools_tasks_are_the_layouts():
    """navigation_train.py (which imports OmniSafe, absent here) takes its choices from TASKS."""
    tree = ast.parse((SOURCE / "tools" / "navigation" / "navigation_train.py").read_text(encoding="utf-8"))
    imported = {
        (node.module, alias.name)
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert ("navigation_layout", "TASKS") in imported
    assert set(nl.TASKS) == set(nl.LAYOUT)


def test_the_layout_is_the_tasks_own(made):
    task_id, env = made
    assert nl.layout_of(env) == nl.LAYOUT[task_id]
    assert env.observation_space.shape == (nl.obs_dim(task_id),)
    assert nl.mismatches(task_id, env) == []


def test_every_column_range_is_the_named_entry_of_the_unflattened_observation(made):
    task_id, env = made
    task = env.unwrapped.task
    env.reset(seed=5)
    rng = np.random.default_rng(0)
    for _ in range(30):
        stepped = env.step(rng.uniform(-1, 1, env.action_space.shape))[0]
    flat = task.obs()  # the observation of this state (its mj_forward recomputes the accelerations)
    np.testing.assert_allclose(flat, stepped, rtol=1e-12, atol=1e-12)
    task.toggle_observation_space()  # the same state, observed as the Dict the flat one comes from
    try:
        entries = task.obs()
    finally:
        task.toggle_observation_space()
    assert list(entries) == [key for key, _ in nl.LAYOUT[task_id]]
    for key, _ in nl.LAYOUT[task_id]:
        got, own = flat[nl.columns(task_id, key)], np.asarray(entries[key]).reshape(-1)
        if key.endswith("_lidar"):  # geometry: exact
            np.testing.assert_array_equal(got, own, err_msg=key)
        else:  # each obs() runs mj_forward again: the accelerations may move by an ulp
            np.testing.assert_allclose(got, own, rtol=1e-12, atol=1e-12, err_msg=key)
    lidars = [tuple(entries[key]) for key in ENTRIES]
    assert len(set(lidars)) == len(lidars), "the lidars read alike here: a swap would go unseen"
    np.testing.assert_array_equal(
        flat[nl.columns(task_id, "hazards_lidar")], task._obs_lidar(task.hazards.pos, task.hazards.group)
    )


def test_the_state_rule_fires_on_the_step_after_each_cost(made):
    task_id, env = made
    obs, costs = drive_into_hazard(task_id, env)
    assert (costs > 0).sum() >= 5, f"{task_id}: the drive never reached a hazard"
    near = obs[1:, nl.columns(task_id, "hazards_lidar")].max(axis=1)
    # The cost measures the distance in the plane; the lidar in the robot's frame, which the car
    # tilts a little: the two may disagree on a step right at the hazard's edge, nowhere else.
    differ = (near > nl.INSIDE) != (costs > 0)
    assert np.all(np.abs(near[differ] - nl.INSIDE) < 1e-3), (near[differ], costs[differ])
    assert differ.sum() <= 2


def test_the_old_car_columns_were_not_the_hazards_lidar():
    """34:50, read as the Car's hazards lidar until navigation_layout.py: goal bins 10-15, hazard
    bins 0-9."""
    car = "SafetyCarGoal1-v0"
    assert nl.columns(car, "goal_lidar") == slice(24, 40)
    assert nl.columns(car, "hazards_lidar") == slice(40, 56)
    assert nl.columns("SafetyPointGoal1-v0", "hazards_lidar") == slice(28, 44)


def test_no_tool_writes_a_column_range_of_its_own():
    """The navigation tools take columns from navigation_layout.py: no other file of
    tools/navigation/ names a range A:B in code (the docstrings may quote the layout's)."""
    folder = SOURCE / "tools" / "navigation"
    for path in sorted(folder.glob("*.py")) + sorted(folder.glob("*.sh")):
        if path.name == "navigation_layout.py":
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if re.search(r"(HAZARDS=\d|slice\(\s*\d+\s*,\s*\d+|\[\s*\d+\s*:\s*\d+\s*\])", code):
                pytest.fail(f"{path.name}:{n}: a column range of its own: {line.strip()}")
