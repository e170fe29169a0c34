"""A learner's training episodes, as a stream of steps, into an episode set labelled by docs/SPEC.md
section 13: what `defender train --record-episodes` writes on a cost task, for a learner that is
not ours (OmniSafe's, driven by tools/navigation/navigation_train.py), so that `defender screen` can replay
it.

The rule (the same as `defender_rl.DemoRecorder(episode_cost_limit=L)` and the Rust
`ViolationTracker`): costs are summed in step order in float64; an episode is **unsafe** once its
sum passes `L` (strictly above), and it is kept up to and including that step (the violation the
filter exists to prevent); **safe** when it reaches `horizon` steps with its sum `<= L`;
**neither** when it ends earlier without passing `L` (the environment terminated it, or the
learner reset it mid-episode, as OmniSafe's on-policy rollout does at an epoch's start when an
epoch is not a whole number of episodes): not kept, only counted.

The steps after an unsafe episode's violation still happen in training; they are summed into the
episode's totals (`rows`: its whole return, cost and length, as the learner's own log counts
them) but are not recorded.
"""

from __future__ import annotations

import math

import numpy as np

#: The `meta` key of a set labelled by an episode cost limit (defender_rl.demos, crates/defender).
EPISODE_COST_LIMIT_KEY = "episode_cost_limit"


class CostLabelledEpisodes:
    """Collects `begin(obs)` / `step(...)` calls into labelled episodes.

    Args:
        limit: the episode cost limit `L` (> 0; the field's 25).
        horizon: the length a safe episode reaches (the task's time limit: 1,000 steps).
    """

    def __init__(self, limit: float = 25.0, horizon: int = 1000) -> None:
        if not (math.isfinite(limit) and limit > 0):
            raise ValueError(f"limit = {limit}: it must be a finite number > 0")
        if horizon < 1:
            raise ValueError(f"horizon = {horizon}: it must be >= 1")
        self.limit, self.horizon = float(limit), int(horizon)
        #: Kept episodes, in the order they ended: (obs [N+1, d], act [N, a], rew [N], unsafe).
        self.episodes: list[tuple[np.ndarray, np.ndarray, np.ndarray, bool]] = []
        #: One row per ended episode, kept or not: (label, length, return, cost, recorded_steps,
        #: first_cost_step), label "safe", "unsafe" or "neither"; length, return and cost are the
        #: whole episode's; first_cost_step the 0-based step of its first cost above 0 (-1: none),
        #: to tell where the filter fired against where the episode began to pay.
        self.rows: list[tuple[str, int, float, float, int, int]] = []
        self._obs: list[np.ndarray] | None = None

    def begin(self, obs: np.ndarray) -> None:
        """An episode starts at `obs` (a reset). An episode in progress with steps ends here as
        neither safe nor unsafe unless it had already passed the limit (then it is kept as
        unsafe: its violation happened)."""
        if self._obs is not None and self._len > 0:
            self._close(reached_horizon=False)
        self._obs = [np.array(obs, dtype=np.float64)]
        self._act: list[np.ndarray] = []
        self._rew: list[float] = []
        self._len, self._ret, self._cost = 0, 0.0, 0.0
        self._violated, self._first_cost = False, -1

    def step(self, action: np.ndarray, reward: float, cost: float, next_obs: np.ndarray, done: bool) -> None:
        """One step of the episode begun last: `next_obs` is the observation it led to (on the
        episode's last step, its final observation, not the next episode's first); `done` when
        the episode ends with it (terminated or truncated)."""
        if self._obs is None:
            raise RuntimeError("step before begin: call begin(obs) at each reset")
        cost = float(cost)
        if not (math.isfinite(cost) and cost >= 0):
            raise ValueError(f"cost {cost} at step {self._len}: a cost must be a finite number >= 0")
        if cost > 0 and self._first_cost < 0:
            self._first_cost = self._len
        self._len += 1
        self._ret += float(reward)
        self._cost += cost
        if not self._violated:
            self._obs.append(np.array(next_obs, dtype=np.float64))
            self._act.append(np.array(action, dtype=np.float64))
            self._rew.append(float(reward))
            self._violated = self._cost > self.limit
        if done:
            self._close(reached_horizon=self._len >= self.horizon)
            self._obs = None

    def _close(self, reached_horizon: bool) -> None:
        if self._violated:
            label = "unsafe"
        elif reached_horizon:
            label = "safe"
        else:
            label = "neither"
        recorded = len(self._act) if label != "neither" else 0
        self.rows.append((label, self._len, self._ret, self._cost, recorded, self._first_cost))
        if label != "neither":
            self.episodes.append((np.stack(self._obs), np.stack(self._act), np.asarray(self._rew), label == "unsafe"))

    @property
    def counts(self) -> dict[str, int]:
        """Ended episodes by label."""
        out = {"safe": 0, "unsafe": 0, "neither": 0}
        for row in self.rows:
            out[row[0]] += 1
        return out

    def episode_set(self, env_id: str, provenance: str, **meta):  # noqa: ANN003, ANN201 (EpisodeSet)
        """The kept episodes as a `defender_rl.EpisodeSet` whose `meta` names the limit (the
        screen and a run check it against their own rule) and `provenance`."""
        from defender_rl import EpisodeSet

        if not self.episodes:
            raise ValueError("no episode was kept (none reached the horizon or passed the limit)")
        obs, act = self.episodes[0][0], self.episodes[0][1]
        full = {
            "obs_dim": int(obs.shape[1]),
            "act_dim": int(act.shape[1]),
            "provenance": provenance,
            EPISODE_COST_LIMIT_KEY: self.limit,
            **meta,
        }
        return EpisodeSet.from_episodes(self.episodes, env_id=env_id, meta=full)
