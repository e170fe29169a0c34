"""Misuse never hangs and bad values are named: DefenderWrapper from two threads, a
re-entrant call from inside the wrapped environment, Ctrl-C during a long selection, NaN and
infinity from the environment or the agent, and arguments of the wrong kind.

The hang repros run in a subprocess with a time limit, so that a regression fails the suite
instead of hanging it."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import gymnasium as gym
import numpy as np
import pytest

import defender_rl
from defender_rl import DefenderError, DefenderWrapper

from conftest import ROOT, DriftEnv

TESTS = ROOT / "python" / "tests"


def run_script(code: str, timeout: float) -> subprocess.CompletedProcess:
    """Runs `code` in a fresh interpreter (the tests' folder on its path); fails on a hang."""
    try:
        return subprocess.run(
            [sys.executable, "-c", textwrap.dedent(code)],
            cwd=TESTS,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired as e:
        pytest.fail(f"hung: no answer within {timeout} s\nstdout: {e.stdout}\nstderr: {e.stderr}")


def test_two_threads_take_turns_and_never_deadlock():
    # The repro: an environment whose step lets the GIL go (as any simulator or networked
    # environment does), stepped from two threads, 300 steps each. It deadlocked forever.
    done = run_script(
        f"""
        import threading, time
        import gymnasium as gym, numpy as np
        from defender_rl import DefenderWrapper, ResetNeeded

        class Sleepy(gym.Wrapper):
            def step(self, action):
                time.sleep(0.0005)
                return self.env.step(action)

        env = DefenderWrapper(Sleepy(gym.make("InvertedDoublePendulum-v5")),
                              "{ROOT}/data/demos/InvertedDoublePendulum-v5.npz", seed=0)
        env.reset(seed=0)
        steps = [0, 0]
        errors = []

        def worker(k):
            rng = np.random.default_rng(k)
            try:
                while steps[k] < 300:
                    try:
                        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, size=1))
                    except ResetNeeded:  # the other thread ended the episode
                        env.reset()
                        continue
                    steps[k] += 1
                    if term or trunc:
                        env.reset()
                    _ = env.defender_stats  # a read from another thread waits its turn too
            except Exception as e:
                errors.append(repr(e))

        threads = [threading.Thread(target=worker, args=(k,)) for k in range(2)]
        for t in threads: t.start()
        for t in threads: t.join()
        assert not errors, errors
        print("steps", steps, env.defender_stats["steps"])
        """,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "steps [300, 300] 600" in done.stdout, done.stdout


@pytest.mark.parametrize("call", ["reset", "step", "close", "stats"])
def test_a_reentrant_call_raises_at_once_naming_both_methods(call):
    done = run_script(
        f"""
        import numpy as np
        from conftest import DriftEnv, drift_demos
        from defender_rl import DefenderWrapper

        class Reentrant(DriftEnv):
            outer = None
            def step(self, action):
                call = "{call}" if self.outer is not None else None
                if call is None: pass
                elif call == "reset": self.outer.reset()
                elif call == "step": self.outer.step(action)
                elif call == "close": self.outer.close()
                else: self.outer.defender_stats
                return super().step(action)

        inner = Reentrant()
        env = DefenderWrapper(inner, drift_demos(), "MinBoth/MinBoth", seed=0)
        inner.outer = env
        env.reset(seed=0)
        try:
            env.step(np.zeros(1, dtype=np.float32))
        except RuntimeError as e:
            print("raised:", e)
        # The wrapper is still usable once the call in progress has returned.
        inner.outer = None
        env.reset(seed=1)
        env.step(np.zeros(1, dtype=np.float32))
        print("usable")
        """,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    method = {"stats": "defender_stats"}.get(call, call)
    assert f"raised: DefenderWrapper.{method}() was called while DefenderWrapper.step() is still running" in done.stdout, done.stdout
    assert "usable" in done.stdout


def test_ctrl_c_stops_a_long_selection_within_a_second():
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(
                f"""
                import signal
                import defender_rl
                # A child of a non-interactive shell may start with SIGINT ignored.
                signal.signal(signal.SIGINT, signal.default_int_handler)
                print("started", flush=True)
                try:
                    defender_rl.select("{ROOT}/data/demos/Hopper-v5.npz", scaling="auto")
                except KeyboardInterrupt:
                    print("interrupted", flush=True)
                """
            ),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "started"
        time.sleep(2.0)  # well inside the selection (tens of seconds)
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=20)
        answered = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "interrupted" in out, err
    # Within a second plus the slack of a loaded 2-core machine.
    assert answered < 5.0, answered


class Faulty(DriftEnv):
    """DriftEnv returning `value` as the reward (`field="reward"`) or as element 1 of the
    observation (`field="obs"`) at step `at` of an episode."""

    def __init__(self, field: str, value: float, at: int = 3):
        super().__init__()
        self.field, self.value, self.at = field, value, at

    def step(self, action):
        obs, r, term, trunc, info = super().step(action)
        if self.episode_steps == self.at:
            if self.field == "reward":
                r = self.value
            else:
                obs = obs.copy()
                obs[1] = self.value
        return obs, r, term, trunc, info


def run_steps(env, n: int, action=None):
    env.reset(seed=0)
    for _ in range(n):
        env.step(np.zeros(1, dtype=np.float32) if action is None else action)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("reward", float("nan"), r"returned a reward of NaN at step 3 of the episode"),
        ("reward", float("-inf"), r"returned a reward of -inf at step 3 of the episode"),
        ("obs", float("inf"), r"observation whose element 1 is inf at step 3 of the episode"),
    ],
)
def test_non_finite_values_from_the_environment_are_named(drift_set, field, value, message):
    env = DefenderWrapper(Faulty(field, value), drift_set, "MinBoth/MinBoth", seed=0)
    with pytest.raises(DefenderError, match=message):
        run_steps(env, 5)


def test_a_non_finite_action_is_named(drift_set):
    env = DefenderWrapper(DriftEnv(), drift_set, "MinBoth/MinBoth", seed=0)
    env.reset(seed=0)
    env.step(np.zeros(1, dtype=np.float32))
    with pytest.raises(DefenderError, match=r"element 0 of the action is NaN at step 2 of the episode"):
        env.step(np.array([np.nan], dtype=np.float32))


def test_check_finite_false_lets_them_through(drift_set):
    env = DefenderWrapper(Faulty("reward", float("nan")), drift_set, "MinBoth/MinBoth", seed=0, check_finite=False)
    env.reset(seed=0)
    rewards = [env.step(np.zeros(1, dtype=np.float32))[1] for _ in range(4)]
    assert np.isnan(rewards[2]) and np.isfinite(rewards[0])


def test_arguments_of_the_wrong_kind_name_the_argument(drift_set):
    with pytest.raises(TypeError, match=r"num_demos must be a whole number or None, got True \(bool\)"):
        DefenderWrapper(DriftEnv(), drift_set, num_demos=True)
    with pytest.raises(DefenderError, match=r"num_demos must be between 1 and 2\*\*63 - 1, got 18446744073709551616"):
        DefenderWrapper(DriftEnv(), drift_set, num_demos=2**64)
    with pytest.raises(DefenderError, match=r"r_task must be a finite number, got nan"):
        DefenderWrapper(DriftEnv(), drift_set, r_task=float("nan"))
    with pytest.raises(DefenderError, match=r"dynamics\['learning_rate'\] must be a finite number, got nan"):
        DefenderWrapper(DriftEnv(), drift_set, dynamics={"learning_rate": float("nan")})
    with pytest.raises(TypeError, match=r"dynamics\['batch_size'\] must be a whole number"):
        DefenderWrapper(DriftEnv(), drift_set, dynamics={"batch_size": True})
    with pytest.raises(DefenderError, match=r"learning_rate = -1: it must be a finite number > 0"):
        DefenderWrapper(DriftEnv(), drift_set, dynamics={"learning_rate": -1.0})
    with pytest.raises(TypeError, match=r"check_finite must be True or False"):
        DefenderWrapper(DriftEnv(), drift_set, check_finite="no")
    with pytest.raises(DefenderError, match=r"select\(num_demos=...\): expected a whole number from 1 to .*, got -1"):
        defender_rl.select(drift_set, num_demos=-1)
    with pytest.raises(TypeError, match=r"select\(min_lead=...\): expected a whole number .* \(a bool\)"):
        defender_rl.select(drift_set, min_lead=True)
    with pytest.raises(DefenderError, match=r"select\(max_false_alarm=...\): expected a fraction from 0 to 1, got NaN"):
        defender_rl.select(drift_set, max_false_alarm=float("nan"))
    with pytest.raises(DefenderError, match=r"select_demos\(n\): expected a whole number from 1 to .*, got 0"):
        drift_set.select_demos(0)
    with pytest.raises(TypeError, match=r"select_demos\(n\): expected a whole number .*\(float\)"):
        drift_set.select_demos(2.0)
    with pytest.raises(DefenderError, match=r"ablate\(threads=...\): expected a whole number from 1 to .*, got -1"):
        defender_rl.ablate(drift_set, drift_set, threads=-1)
    # numpy integers are whole numbers.
    assert drift_set.select_demos(np.int64(2)).group_sizes == (2, 2)


def test_a_gymnasium_env_under_threads_is_not_needed_for_plain_use():
    # The turn costs nothing visible to a single-threaded user: the usual loop still works.
    env = DefenderWrapper(gym.make("InvertedDoublePendulum-v5"), ROOT / "data/demos/InvertedDoublePendulum-v5.npz", seed=0)
    env.reset(seed=0)
    for _ in range(10):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    env.close()
    with pytest.raises(RuntimeError, match=r"DefenderWrapper.step\(\): the wrapper is closed"):
        env.step(np.zeros(1))
