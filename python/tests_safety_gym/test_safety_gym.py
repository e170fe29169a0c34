"""The wheel beside safety-gymnasium 1.0.0 (numpy 1.23.5, gymnasium 0.28.1, mujoco 2.3.3, Python
3.10), as a safe-RL researcher installs it: run by scripts/test-beside-safety-gym.sh in a fresh
venv of that stack, after it checked that installing the wheel changed none of its packages.
Here: the wrapper on a Safety-Gymnasium task with its cost flowing, cost-labelled demonstrations
recorded on SafetyPointGoal1-v0 (a new random layout every episode, seeded by numpy's
``RandomState``, which takes 32-bit seeds only), and the command line's word on its runtime.
"""

from __future__ import annotations

import importlib.metadata
import os
import pathlib
import subprocess
import sysconfig
import warnings

import gymnasium as gym
import numpy as np

import defender_rl
from defender_rl import DefenderWrapper, DemoRecorder, EpisodeSet, collect_demos
from defender_rl.demos import reset_seed

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
    import safety_gymnasium
    from safety_gymnasium.wrappers import SafetyGymnasium2Gymnasium

SOURCE = pathlib.Path(os.environ["DEFENDER_SOURCE_TREE"])
HOPPER_DEMOS = SOURCE / "data" / "demos" / "SafetyHopperVelocity-v1.npz"


class Spy(gym.Wrapper):
    """Keeps the costs of the steps the environment really took, per episode, and every reset's
    seed."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self.episodes: list[list[float]] = []
        self.seeds: list[int | None] = []

    @property
    def costs(self) -> list[float]:
        return [c for e in self.episodes for c in e]

    def reset(self, *, seed=None, options=None):
        self.seeds.append(seed)
        self.episodes.append([])
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        out = self.env.step(action)
        self.episodes[-1].append(float(out[4]["cost"]))
        return out


def test_their_stack_and_one_mujoco_runtime():
    versions = {d: importlib.metadata.version(d) for d in ("numpy", "gymnasium", "mujoco", "safety-gymnasium")}
    assert versions == {"numpy": "1.23.5", "gymnasium": "0.28.1", "mujoco": "2.3.3", "safety-gymnasium": "1.0.0"}
    # The extension links no MuJoCo: the process keeps safety-gymnasium's 2.3.3 alone.
    assert b"libmujoco" not in pathlib.Path(defender_rl._core.__file__).read_bytes()


def test_the_command_names_how_to_get_its_runtime(tmp_path):
    # mujoco 2.3.3 is installed, the binary links 3.17.0's runtime: a message, not a loader error.
    script = pathlib.Path(sysconfig.get_path("scripts")) / "defender"
    done = subprocess.run([str(script), "env", "list"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    err = done.stderr
    assert "libmujoco.so.3.17.0" in err and "mujoco 2.3.3" in err and "defender-rl[cli]" in err, err
    assert "venv of its own" in err and "Traceback" not in err, err


def test_the_wrapper_steps_safety_hopper_and_its_cost_flows():
    # The actions of the set's unsafe demonstrations, replayed: fast running, which costs on
    # SafetyHopperVelocity-v1 (velocity above its threshold). Every step that reached the
    # environment returns the environment's cost in info["cost"]; a filtered one costs 0.
    spy = Spy(SafetyGymnasium2Gymnasium(safety_gymnasium.make("SafetyHopperVelocity-v1")))
    env = DefenderWrapper(spy, str(HOPPER_DEMOS), "MeanDemoW5/MeanDemoW10", seed=0, episode_cost_limit=25)
    demos = EpisodeSet.load(str(HOPPER_DEMOS))
    flowed, outcomes = [], []
    for i in range(len(demos)):
        if not demos.episode(i)["crashed"] or len(outcomes) == 6:
            continue
        env.reset(seed=i)
        for action in demos.episode(i)["act"]:
            taken = len(spy.costs)
            obs, reward, terminated, truncated, info = env.step(action.astype(np.float64))
            if info["defender_filtered"]:
                assert info["cost"] == 0.0 and len(spy.costs) == taken
            else:
                assert info["cost"] == spy.costs[-1]
                flowed.append(info["cost"])
            if terminated or truncated:
                outcomes.append(info["defender_outcome"])
                break
    assert sum(flowed) > 0, "no step of the replayed running cost anything"
    assert np.isfinite(reward) and obs.shape == (11,)
    assert env.defender_stats["episodes"] == len(outcomes) > 0
    env.close()


def seek_hazard(env: gym.Env):
    """Drives the point robot into its nearest hazard (each step inside one costs 1)."""
    task = env.unwrapped.task

    def policy(obs):
        nearest = min(task.hazards.pos, key=lambda p: task.agent.dist_xy(np.asarray(p[:2])))
        ego = task._ego_xy(np.asarray(nearest[:2]))
        return np.clip(5 * ego, -1, 1)

    return policy


def point_goal() -> Spy:
    # The conversion the user took, with Safety-Gymnasium's own ``make``.
    return Spy(SafetyGymnasium2Gymnasium(safety_gymnasium.make("SafetyPointGoal1-v0")))


def test_the_first_reset_of_point_goal_takes_the_recorders_seed():
    env = point_goal()
    rec = DemoRecorder(env, seed=0, episode_cost_limit=25)
    rec.record(lambda obs: np.zeros(2), after_episode=0)  # the ValueError was here
    assert env.seeds == [reset_seed(0, 0)] and env.seeds[0] < 2**32
    # Standing still for the whole horizon (1,000 steps) costs nothing: safe.
    assert rec.group_sizes == (1, 0) and len(rec.candidates[0][2]) == 1000


def test_collect_demos_labels_point_goal_by_the_episode_cost_limit():
    # Odd "training" episodes seek a hazard, even ones stand still: the recorder cuts an unsafe
    # one on the step its cost passed 25 and keeps a still one (cost 0 over 1,000 steps) as safe.
    env = point_goal()
    seek, phase = seek_hazard(env), {"k": 0}

    def train(k):
        phase["k"] = k

    def policy(obs):
        return seek(obs) if phase["k"] % 2 else np.zeros(2)

    demos = collect_demos(env, policy, 1, 1, train=train, seed=3, max_episodes=20, episode_cost_limit=25)
    assert demos.group_sizes == (1, 1)
    meta = demos.meta
    assert meta["episode_cost_limit"] == 25.0 and "cost passed 25" in meta["provenance"]
    assert all(s < 2**32 for s in env.seeds) and env.seeds == [reset_seed(3, k) for k in range(len(env.seeds))]
    # The unsafe demonstration stops on the step where its episode's cost passed 25.
    unsafe = next(i for i in range(len(demos)) if demos.episode(i)["crashed"])
    costs = np.cumsum(env.episodes[meta["source_training_episodes"][unsafe]])
    assert len(demos.episode(unsafe)["rew"]) == len(costs)
    assert costs[-1] > 25 and (len(costs) == 1 or costs[-2] <= 25)
    # The set is what a wrapper on the task takes, with the set's limit.
    DefenderWrapper(point_goal(), demos, "MeanDemoW5/MeanDemoW10", seed=0)


def test_recorded_sets_are_reproducible():
    # The layouts and the robot's start come from the 32-bit seed: the same seed, the same set.
    runs = []
    for _ in range(2):
        env = point_goal()
        rec = DemoRecorder(env, seed=11, episode_cost_limit=25)
        rec.record(seek_hazard(env), after_episode=1)
        runs.append(rec.candidates[0])
    for a, b in zip(runs[0], runs[1]):
        np.testing.assert_array_equal(a, b)
