"""tools/navigation/navigation_episodes.py on SafetyPointGoal1-v0: a learner's training episodes, fed step by
step, labelled and cut by docs/SPEC.md section 13 exactly as `defender_rl.DemoRecorder` labels and
cuts a recorded one (the screen's episodes and the demonstrations must follow one rule), and the
set `defender screen` reads. Seconds: a few hundred steps of the point robot.
"""

from __future__ import annotations

import os
import pathlib
import sys
import warnings

import numpy as np
import pytest

from defender_rl import DemoRecorder, EpisodeSet
from defender_rl.demos import reset_seed

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
    import safety_gymnasium
    from safety_gymnasium.wrappers import SafetyGymnasium2Gymnasium

SOURCE = pathlib.Path(os.environ.get("DEFENDER_SOURCE_TREE", pathlib.Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(SOURCE / "tools" / "navigation"))
from navigation_episodes import CostLabelledEpisodes  # noqa: E402


def seek_hazard(env):
    """Drives the point robot into its nearest hazard (each step inside one costs 1)."""
    task = env.unwrapped.task

    def policy(obs):
        nearest = min(task.hazards.pos, key=lambda p: task.agent.dist_xy(np.asarray(p[:2])))
        return np.clip(5 * task._ego_xy(np.asarray(nearest[:2])), -1, 1)

    return policy


class Feed:
    """Steps an environment with a policy, reporting every step to a CostLabelledEpisodes as a
    learner's rollout does (the final observation of an episode, not the next one's first).
    Safety-Gymnasium builds a new world at every reset (about a second): an episode given no
    seed goes on from where the last one stopped, which the log cannot tell from a reset."""

    def __init__(self, env, log: CostLabelledEpisodes):
        self.env, self.log, self.obs = env, log, None

    def episode(self, policy, seed: int | None, steps: int | None = None, time_limit: bool = False) -> list[float]:
        """Runs to the episode's end, or `steps` steps (then its last step is a time limit's
        truncation when `time_limit`, else the episode is left open, as a learner's mid-episode
        reset leaves it)."""
        obs = self.env.reset(seed=seed)[0] if seed is not None else self.obs
        self.log.begin(obs)
        costs = []
        for i in range(steps or 10**6):
            action = policy(obs)
            obs, reward, terminated, truncated, info = self.env.step(action)
            costs.append(float(info["cost"]))
            done = terminated or truncated or (time_limit and i + 1 == steps)
            self.log.step(action, reward, info["cost"], obs, done)
            if done:
                break
        self.obs = obs
        return costs


def point_goal():
    return SafetyGymnasium2Gymnasium(safety_gymnasium.make("SafetyPointGoal1-v0"))


def test_a_training_episode_is_cut_as_the_recorder_cuts_it():
    # The same episode (same reset seed, same policy) through DemoRecorder and through the log:
    # the same observations, actions and rewards up to the step that passed 25, the same label.
    env = point_goal()
    rec = DemoRecorder(env, seed=5, episode_cost_limit=25)
    rec.record(seek_hazard(env), after_episode=0)
    assert rec.group_sizes == (0, 1)
    n = len(rec.candidates[0][2])
    # The training episode goes on after its violation, to a time limit 20 steps later.
    log = CostLabelledEpisodes(25.0, n + 20)
    costs = Feed(env, log).episode(seek_hazard(env), reset_seed(5, 0), steps=n + 20, time_limit=True)
    (kept,) = log.episodes
    for ours, theirs in zip(kept[:3], rec.candidates[0][:3]):
        np.testing.assert_array_equal(ours, theirs)
    assert kept[3] is True
    cum = np.cumsum(costs)
    assert len(kept[2]) == n and cum[n - 1] > 25 and cum[n - 2] <= 25, "cut on the step whose cost passed 25"
    # The row counts the whole episode: its cost, length and first paying step.
    label, length, _ret, cost, recorded, first = log.rows[0]
    assert (label, length, recorded) == ("unsafe", n + 20, n) and cost == cum[-1]
    assert first == int(np.argmax(np.asarray(costs) > 0))


def test_safe_unsafe_neither_and_the_set_the_screen_reads(tmp_path):
    env = point_goal()
    still = lambda obs: np.zeros(2)  # noqa: E731
    # A horizon of 100 steps (the task's is 1,000): standing still to it costs 0, safe.
    log = CostLabelledEpisodes(25.0, 100)
    feed = Feed(env, log)
    feed.episode(still, seed=2, steps=100, time_limit=True)  # seek_hazard passes 25 from here
    feed.episode(still, None, steps=99, time_limit=True)  # ended short of the horizon
    feed.episode(still, None, steps=30)  # then left open by a reset mid-episode
    log.begin(feed.obs)
    assert log.counts == {"safe": 1, "unsafe": 0, "neither": 2}
    assert [r[0] for r in log.rows] == ["safe", "neither", "neither"] and log.rows[0][5] == -1
    assert len(log.episodes) == 1 and log.episodes[0][0].shape == (101, 60)
    # A reset after the violation keeps the episode as unsafe: the violation happened.
    feed.episode(seek_hazard(env), None, steps=400)
    log.begin(feed.obs)
    assert log.counts["unsafe"] == 1 and log.episodes[-1][3] is True
    # The set: the limit in its meta (the screen checks it against the demonstrations').
    path = tmp_path / "episodes.npz"
    log.episode_set("SafetyPointGoal1-v0", "a test", seed=7).save(str(path))
    back = EpisodeSet.load(str(path))
    assert back.meta["episode_cost_limit"] == 25.0 and back.meta["obs_dim"] == 60
    assert back.group_sizes == (1, 1) and back.meta["provenance"] == "a test"
    assert len(back.episode(1)["rew"]) < 400


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="no episode"):
        CostLabelledEpisodes().episode_set("SafetyPointGoal1-v0", "empty")
    log = CostLabelledEpisodes()
    with pytest.raises(RuntimeError, match="begin"):
        log.step(np.zeros(2), 0.0, 0.0, np.zeros(60), False)
    log.begin(np.zeros(60))
    with pytest.raises(ValueError, match="cost"):
        log.step(np.zeros(2), 0.0, -1.0, np.zeros(60), False)
    with pytest.raises(ValueError, match="limit"):
        CostLabelledEpisodes(0.0)
