"""Property tests of the arguments the Python API converts before they reach Rust: for
any value of any type in any argument of DefenderWrapper, select, DemoRecorder and collect_demos,
the call either works or raises ValueError, TypeError or DefenderError (a ValueError) whose
message names the argument. Never a Rust panic (pyo3's PanicException is no Exception, so it
fails these tests), an OverflowError from a conversion, or an error that leaves the user to guess
which argument was wrong.

The example counts are modest (the whole file runs in seconds); hypothesis shrinks a failure to
the smallest value that shows it."""

from __future__ import annotations

import os

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")  # python/requirements-test.txt installs it
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import defender_rl  # noqa: E402
from defender_rl import DefenderError, DefenderWrapper  # noqa: E402

from conftest import DriftEnv, drift_demos  # noqa: E402

# Built once: hypothesis runs every example in one test call.
DEMOS = drift_demos()

#: Values of every kind a caller might pass by mistake: None, bools (numpy's too), whole numbers
#: far beyond 64 bits either way, floats with NaN and infinities, numpy scalars, strings, lists.
ANY = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([0, 1, -1, 2**63 - 1, 2**63, 2**64 - 1, 2**64]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([np.int64(3), np.int64(-3), np.uint64(2**64 - 1), np.float32("nan"), np.bool_(True)]),
    st.text(max_size=12),
    st.sampled_from(["MeanDemoW5/MeanDemoW10", "MinBoth/MinBoth", "state", "state-action", "zscore", "none"]),
    st.lists(st.integers(min_value=-3, max_value=3), max_size=3),
)

ERRORS = (ValueError, TypeError, DefenderError)
EXAMPLES = settings(max_examples=int(os.environ.get("DEFENDER_HYPOTHESIS_EXAMPLES", "40")), deadline=None, database=None)


def named(call, *names: str) -> bool:
    """Runs ``call``; an error must be one of ERRORS and name one of ``names``. Returns whether
    the call worked."""
    try:
        call()
    except ERRORS as e:
        message = str(e)
        assert any(n in message for n in names), f"{type(e).__name__} names none of {names}: {message}"
        return False
    return True


@pytest.mark.parametrize("arg", ["num_demos", "r_task", "seed", "strategy", "mode", "scaling", "check_finite"])
@EXAMPLES
@given(value=ANY)
def test_wrapper_arguments_work_or_are_named(arg, value):
    def build_and_step():
        env = DefenderWrapper(DriftEnv(), DEMOS, **({"strategy": "MinBoth/MinBoth"} if arg != "strategy" else {}), **{arg: value})
        env.reset(seed=0)
        env.step(np.zeros(1, dtype=np.float32))

    if isinstance(value, str) and value.strip() == "auto":
        return  # a strategy selection: seconds per example, tested in test_select.py
    named(build_and_step, arg)


DYNAMICS_KEYS = ["hidden", "learning_rate", "batch_size", "buffer_size", "learning_starts", "train_freq",
                 "gradient_steps", "error_ema_alpha", "background"]


@EXAMPLES
@given(key=st.one_of(st.sampled_from(DYNAMICS_KEYS), st.text(max_size=8)), value=ANY)
def test_dynamics_settings_work_or_are_named(key, value):
    # A huge layer or buffer is a legal request that would take the machine's memory: keep the
    # widths that work small (the range checks are what is under test).
    if key == "hidden" and isinstance(value, list) and all(isinstance(v, int) and 0 < v < 64 for v in value):
        value = [int(v) for v in value]

    def build():
        env = DefenderWrapper(DriftEnv(), DEMOS, "MinBoth/MinBoth", dynamics={key: value}, seed=0)
        env.reset(seed=0)
        env.step(np.zeros(1, dtype=np.float32))

    named(build, repr(key), str(key), "dynamics")


@pytest.mark.parametrize("arg", ["num_demos", "min_lead", "max_false_alarm", "mode", "scaling", "equal", "strategies"])
@EXAMPLES
@given(value=ANY)
def test_select_arguments_work_or_are_named(arg, value):
    # One strategy keeps each example to milliseconds (the full selection is test_select.py's).
    base = {} if arg == "strategies" else {"strategies": ["MinBoth/MinBoth"]}
    if arg == "scaling" and value == "auto":
        return
    named(lambda: defender_rl.select(DEMOS, **base, **{arg: value}), arg)


def policy(obs):
    return np.array([1.0])  # full throttle: every episode crashes within a few dozen steps


@pytest.mark.parametrize("arg", ["seed", "max_steps", "horizon"])
@EXAMPLES
@given(value=ANY)
def test_demo_recorder_arguments_work_or_are_named(arg, value):
    def record():
        recorder = defender_rl.DemoRecorder(DriftEnv(), **{arg: value})
        recorder.record(policy)

    named(record, arg)


@pytest.mark.parametrize("arg", ["n_safe", "n_unsafe", "max_episodes", "seed", "horizon"])
@EXAMPLES
@given(value=ANY)
def test_collect_demos_arguments_work_or_are_named(arg, value):
    import gymnasium as gym

    # horizon=0: every episode that did not crash is safe, so valid requests finish at once.
    args = {"n_safe": 1, "n_unsafe": 1, "max_episodes": 3, "horizon": 0}
    args[arg] = value
    env = gym.wrappers.TimeLimit(DriftEnv(), max_episode_steps=30)
    # Full throttle (a crash) after odd training episodes, a controller (safe) after even ones.
    crash = [False]

    def train(k):
        crash[0] = k % 2 == 1

    def policy_k(obs):
        return np.array([1.0]) if crash[0] else np.clip([-3 * obs[0] - 2 * obs[1]], -1, 1)

    named(lambda: defender_rl.collect_demos(env, policy_k, train=train, **args), arg)
