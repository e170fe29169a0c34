"""Stable-Baselines3 integration (``pip install defender-rl[sb3]``).

* :class:`DefenderCallback` logs DEFENDER's crash and filter rates through SB3's logger (so
  TensorBoard and the console see them) from the ``info`` keys of :class:`DefenderWrapper`,
  whatever the vector environment (``DummyVecEnv`` or ``SubprocVecEnv``).
* :class:`DemoCollectorCallback` records demonstrations as the paper does while SB3 trains.
"""

from __future__ import annotations

import math
import warnings
from collections import deque

from stable_baselines3.common.callbacks import BaseCallback

from .demos import DemoRecorder


class DefenderCallback(BaseCallback):
    """Logs, under ``defender/``: ``crash_rate`` and ``filter_rate`` (cumulative fractions of
    finished training episodes that crashed / that DEFENDER ended), ``crashes`` and
    ``filtered_episodes`` (counts), ``episodes``, ``crash_rate_recent`` /
    ``filter_rate_recent`` (over the last ``window`` episodes), and ``filtered_step_rate``
    (fraction of steps filtered); ``mean_safe_cost`` and ``mean_unsafe_cost`` (the mean DTW costs
    ``Safe(tau)`` and ``Unsafe(tau)`` of the steps since the last record) and ``dynamics_error``
    (the dynamics model's moving-average prediction error on fresh transitions, averaged over the
    environments) at each episode's end; and ``r_task`` once when training starts. The names are
    those of the TensorBoard files ``defender train`` writes, so both kinds of run compare in one
    TensorBoard. With ``strategy="auto"``, the strategy chosen and its scores are logged once when
    training starts (``defender/strategy``, ``defender/scaling``, ``defender/selection/*``).

    At the start it also warns when part of the run would do nothing: the agent's
    ``learning_starts`` at or beyond ``total_timesteps`` (it never updates), or the dynamics
    model's (it never trains)."""

    def __init__(self, window: int = 100, verbose: int = 0):
        super().__init__(verbose)
        self.window = window
        self.recent: deque[str] = deque(maxlen=window)
        self.counts = {"crashed": 0, "filtered": 0, "truncated": 0}
        self.steps = 0
        self.filtered_steps = 0
        self._costs = [0.0, 0.0, 0]

    def _warn_inert(self) -> None:
        total = self.locals.get("total_timesteps")
        if total is None:
            return
        # SB3 counts timesteps across its environments, as learning_starts does.
        starts = getattr(self.model, "learning_starts", None)
        if starts is not None and starts >= total:
            warnings.warn(
                f"learning_starts = {starts} is at or beyond total_timesteps = {total}: the agent never updates; "
                "lower the model's learning_starts or raise total_timesteps",
                UserWarning,
                stacklevel=2,
            )
        try:
            starts = max(self.training_env.get_attr("dynamics_learning_starts"), default=0)
        except AttributeError:
            return
        per_env = total / max(self.training_env.num_envs, 1)
        if starts >= per_env:
            warnings.warn(
                f"DefenderWrapper(dynamics={{'learning_starts': {int(starts)}}}) is at or beyond the "
                f"{int(per_env)} steps each environment takes: DEFENDER's dynamics model never trains; "
                "lower dynamics['learning_starts'] or raise total_timesteps",
                UserWarning,
                stacklevel=2,
            )

    def _on_training_start(self) -> None:
        self._warn_inert()
        try:
            selections = self.training_env.get_attr("strategy_selection")
        except AttributeError:  # not a DefenderWrapper underneath
            return
        self.logger.record("defender/r_task", float(self.training_env.get_attr("r_task")[0]))
        chosen = next((s for s in selections if s is not None), None)
        if chosen is None:
            return
        self.logger.record("defender/strategy", chosen["strategy"])
        self.logger.record("defender/scaling", chosen["scaling"])
        for key in ("false_alarm_rate", "crash_prevention_rate", "safe_allowed", "mean_lead", "score"):
            self.logger.record(f"defender/selection/{key}", chosen[key])

    def _on_step(self) -> bool:
        for info in self.locals.get("infos", ()):
            self.steps += 1
            if info.get("defender_filtered"):
                self.filtered_steps += 1
            safe, unsafe = info.get("defender_safe_cost"), info.get("defender_unsafe_cost")
            if safe is not None and unsafe is not None and math.isfinite(safe) and math.isfinite(unsafe):
                self._costs[0] += safe
                self._costs[1] += unsafe
                self._costs[2] += 1
            outcome = info.get("defender_outcome")
            if outcome is not None:
                self.counts[outcome] += 1
                self.recent.append(outcome)
                self._record()
        return True

    def _record(self) -> None:
        episodes = sum(self.counts.values())
        log = self.logger.record
        log("defender/episodes", episodes)
        log("defender/crashes", self.counts["crashed"])
        log("defender/filtered_episodes", self.counts["filtered"])
        log("defender/crash_rate", self.counts["crashed"] / episodes)
        log("defender/filter_rate", self.counts["filtered"] / episodes)
        n = len(self.recent)
        log("defender/crash_rate_recent", sum(o == "crashed" for o in self.recent) / n)
        log("defender/filter_rate_recent", sum(o == "filtered" for o in self.recent) / n)
        log("defender/filtered_step_rate", self.filtered_steps / max(self.steps, 1))
        if self._costs[2]:
            log("defender/mean_safe_cost", self._costs[0] / self._costs[2])
            log("defender/mean_unsafe_cost", self._costs[1] / self._costs[2])
            self._costs = [0.0, 0.0, 0]
        try:
            errors = [d["prediction_error_ema"] for d in self.training_env.get_attr("dynamics_info")]
        except (AttributeError, KeyError):
            errors = []
        if errors:
            log("defender/dynamics_error", sum(errors) / len(errors))

    @property
    def crash_rate(self) -> float:
        episodes = sum(self.counts.values())
        return self.counts["crashed"] / episodes if episodes else 0.0


class DemoCollectorCallback(BaseCallback):
    """Records demonstrations while an SB3 agent trains, as ``defender demos collect``: after
    every training episode that ends past ``learning_starts`` steps, one episode of the
    deterministic policy (``model.predict(obs, deterministic=True)``) on ``recorder``'s own
    environment. Training stops once both groups have ``n_safe`` / ``n_unsafe`` candidates; then
    ``recorder.select(n_safe, n_unsafe)`` gives the demonstrations. Use one training env."""

    def __init__(self, recorder: DemoRecorder, n_safe: int, n_unsafe: int, learning_starts: int | None = None):
        super().__init__(0)
        self.recorder = recorder
        self.n_safe, self.n_unsafe = n_safe, n_unsafe
        self.learning_starts = learning_starts
        self.episodes = 0

    def _policy(self, obs):
        return self.model.predict(obs, deterministic=True)[0]

    def _on_step(self) -> bool:
        starts = self.learning_starts if self.learning_starts is not None else getattr(self.model, "learning_starts", 0)
        for done in self.locals.get("dones", ()):
            if done:
                if self.num_timesteps > starts:
                    self.recorder.record(self._policy, after_episode=self.episodes)
                self.episodes += 1
        return not self.recorder.enough(self.n_safe, self.n_unsafe)
