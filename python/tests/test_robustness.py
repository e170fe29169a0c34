"""What a new user and a hostile tester hit, held: every exception of the package
crosses process boundaries with its message (a vector environment's worker reports its error
instead of hanging the parent), own episodes cut by a shorter time limit never fill the safe
group, and the messages say what to do once."""

from __future__ import annotations

import multiprocessing
import pickle
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderError, DefenderWrapper, ResetNeeded
from defender_rl._cli import LaunchError

from conftest import HOPPER_DEMOS, DriftEnv

EXCEPTIONS = (DefenderError, ResetNeeded, LaunchError)


@pytest.mark.parametrize("cls", EXCEPTIONS, ids=lambda c: c.__name__)
def test_every_exception_of_the_package_pickles_with_its_message(cls):
    err = cls("step 3: action[1] is nan")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is cls and str(back) == str(err)


def _raise_in_child(name: str) -> None:
    raise getattr(defender_rl, name)(f"{name} from a worker")


@pytest.mark.parametrize("name", ["DefenderError", "ResetNeeded"])
def test_an_exception_raised_in_another_process_arrives_with_its_message(name):
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(1) as pool:
        with pytest.raises(getattr(defender_rl, name), match=f"{name} from a worker"):
            pool.apply(_raise_in_child, (name,))


def test_a_real_error_of_the_wrapper_pickles(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, seed=0)
    env.reset(seed=0)
    with pytest.raises(DefenderError) as caught:
        env.step(np.array([np.nan], dtype=np.float32))
    back = pickle.loads(pickle.dumps(caught.value))
    assert type(back) is DefenderError and str(back) == str(caught.value)


def test_an_error_in_an_async_vector_worker_reaches_the_parent():
    # In a process of its own: before the fix, the parent waited forever.
    script = textwrap.dedent(
        f"""
        import gymnasium as gym, numpy as np
        from defender_rl import DefenderWrapper
        envs = gym.vector.AsyncVectorEnv(
            [lambda: DefenderWrapper(gym.make("Hopper-v5"), {str(HOPPER_DEMOS)!r}, seed=0)] * 2)
        envs.reset(seed=0)
        action = np.zeros((2, 3), dtype=np.float32)
        action[1, 1] = np.nan
        try:
            envs.step(action)
        except Exception as e:
            print("RAISED", type(e).__name__, e)
        else:
            print("NO ERROR")
        envs.close(terminate=True)
        """
    )
    try:
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=180)
    except subprocess.TimeoutExpired:
        pytest.fail("AsyncVectorEnv hung on an error in its worker")
    assert "RAISED DefenderError" in done.stdout, done.stdout + done.stderr
    assert "nan" in done.stdout.lower(), done.stdout


def test_episodes_cut_by_a_shorter_time_limit_never_join_the_safe_group():
    env = gym.make("Hopper-v5", max_episode_steps=20)
    with pytest.warns(UserWarning, match=r"time limit \(max_episode_steps=20\) differs from the horizon the demonstrations were made with \(1000 steps"):
        wrapped = DefenderWrapper(env, HOPPER_DEMOS, seed=0)
    truncated = 0
    for episode in range(100):
        wrapped.reset(seed=episode)
        while True:
            _, _, term, trunc, info = wrapped.step(np.zeros(3, dtype=np.float32))
            if term or trunc:
                truncated += info.get("defender_outcome") == "truncated"
                break
    assert truncated > 50, truncated
    assert wrapped.filter_state["own_safe"] == 0, wrapped.filter_state


def test_a_discrete_action_space_is_not_sent_to_an_observation_wrapper(drift_set):
    class DiscreteActions(DriftEnv):
        def __init__(self):
            super().__init__()
            self.action_space = gym.spaces.Discrete(3)

    with pytest.raises(TypeError) as caught:
        DefenderWrapper(DiscreteActions(), drift_set)
    assert "action space" in str(caught.value) and "continuous actions" in str(caught.value)
    assert "FlattenObservation" not in str(caught.value)


def test_the_strategy_error_gives_its_example_once(drift_set):
    with pytest.raises(DefenderError) as caught:
        DefenderWrapper(DriftEnv(), drift_set, "Foo/Bar")
    assert str(caught.value).count("e.g.") == 1, caught.value


def test_the_wrong_demonstrations_name_their_file_once():
    with pytest.raises(DefenderError) as caught:
        DefenderWrapper(gym.make("Walker2d-v5"), HOPPER_DEMOS)
    assert str(caught.value).count(HOPPER_DEMOS.name) == 1, caught.value


def test_strategy_auto_says_what_it_is_doing(drift_set, capfd, monkeypatch):
    monkeypatch.delenv("DEFENDER_PROGRESS_INTERVAL", raising=False)
    env = DefenderWrapper(DriftEnv(), drift_set, "auto", seed=0)
    err = capfd.readouterr().err
    assert "strategy='auto': ranking the strategies" in err and f"chose {env.strategy}" in err, err
    monkeypatch.setenv("DEFENDER_PROGRESS_INTERVAL", "off")
    DefenderWrapper(DriftEnv(), drift_set, "auto", seed=0)
    assert capfd.readouterr().err == ""
