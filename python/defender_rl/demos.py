"""Recording demonstrations as the paper does (and as ``defender demos collect`` does).

The procedure: train an agent and, after every training episode once it has started learning,
record one episode of its current (deterministic) policy on a separate copy of the environment.
Every recorded episode is a candidate: unsafe if the environment terminated it (it crashed),
safe if it reached the task's horizon (the ``max_episode_steps`` Gymnasium registers for the
task) without terminating. An episode cut earlier by a shorter time limit is neither and is not
kept (a warning says so once), unless ``horizon`` sets another length. Once both groups have enough candidates, N of each are
taken at evenly spaced positions of their candidate lists (first and last included), so that the
unsafe group spans the whole run, from the falls of a barely trained policy to the rare falls of
a good one (docs/decisions.md explains what went wrong otherwise).

:class:`DemoRecorder` does the recording and the selection for any policy callable on any
Gymnasium environment; ``defender_rl.sb3.DemoCollectorCallback`` drives it from an SB3 agent's
training loop, and :func:`collect_demos` from a loop of your own.
"""

from __future__ import annotations

from typing import Any, Callable

import gymnasium as gym
import numpy as np

import warnings

from ._args import I64_MAX, U64_MAX, whole
from ._core import DefenderError, EpisodeSet, derive_seed
from .horizon import env_horizon


def own_time_limit(env: gym.Env) -> int | None:
    """The time limit the environment itself applies (a ``TimeLimit`` wrapper, else its spec's
    ``max_episode_steps``), if any."""
    e = env
    while isinstance(e, gym.Wrapper):
        if isinstance(e, gym.wrappers.TimeLimit):
            return int(e._max_episode_steps)
        e = e.env
    spec = getattr(env, "spec", None)
    return int(spec.max_episode_steps) if spec is not None and spec.max_episode_steps else None


def spread(items: list[int], n: int) -> list[int]:
    """``n`` items at evenly spaced positions, first and last included (as the Rust ``spread``)."""
    if n == 1:
        return [items[-1]]
    return [items[(k * (len(items) - 1) + (n - 1) // 2) // (n - 1)] for k in range(n)]


class DemoRecorder:
    """Records episodes of a policy as demonstration candidates and picks the demonstrations.

    Args:
        env: the environment to record on (a separate copy from the one the agent trains on), or
            a Gymnasium id for ``gymnasium.make``.
        seed: the demonstration after training episode ``k`` resets with
            ``derive_seed(seed, "demonstration", k)``, as ``defender demos collect`` does.
        max_steps: a cap on the length of one recorded episode (the environment's own time limit
            applies first).
        horizon: the length a safe episode reaches; default: the task's horizon (the
            ``max_episode_steps`` Gymnasium registers for the environment's id, else its own time
            limit); 0 counts every episode that did not terminate as safe.
    """

    def __init__(self, env: gym.Env | str, *, seed: int = 0, max_steps: int = 100_000, horizon: int | None = None):
        self.seed = whole("seed", seed, 0, U64_MAX)
        self.max_steps = whole("max_steps", max_steps, 1, I64_MAX)
        horizon = whole("horizon", horizon, 0, I64_MAX, optional=True)
        self.env = gym.make(env) if isinstance(env, str) else env
        self.env_id = self.env.spec.id if self.env.spec is not None else None
        self.horizon = env_horizon(self.env) if horizon is None else horizon
        limit = own_time_limit(self.env)
        if horizon and limit is not None and limit < horizon:
            # Every episode would be cut before the horizon: none could ever count as safe.
            raise DefenderError(
                f"horizon = {horizon} is beyond the environment's time limit of {limit} steps, so no "
                f"episode could count as safe; give horizon <= {limit} (0 counts every episode that did "
                "not terminate as safe)"
            )
        self.candidates: list[tuple[np.ndarray, np.ndarray, np.ndarray, bool]] = []
        self.sources: list[int] = []
        self.left_out: list[int] = []

    def record(self, policy: Callable[[np.ndarray], Any], after_episode: int | None = None) -> bool:
        """Runs one episode of ``policy(obs) -> action`` and keeps it as a candidate (unless it
        neither crashed nor reached the horizon: then it is left out and counted in
        ``left_out``). Returns whether it crashed (the environment terminated it)."""
        k = len(self.sources) if after_episode is None else int(after_episode)
        obs, _ = self.env.reset(seed=derive_seed(self.seed, "demonstration", k))
        observations, actions, rewards = [np.asarray(obs, dtype=np.float64)], [], []
        crashed = False
        for _ in range(self.max_steps):
            action = np.asarray(policy(obs), dtype=np.float64)
            obs, reward, terminated, truncated, _ = self.env.step(action)
            observations.append(np.asarray(obs, dtype=np.float64))
            actions.append(action)
            rewards.append(float(reward))
            if terminated or truncated:
                crashed = bool(terminated)  # SPEC section 6
                break
        if not crashed and self.horizon and len(rewards) < self.horizon:
            if not self.left_out:
                warnings.warn(
                    f"DemoRecorder: an episode ended after {len(rewards)} steps without terminating, before the "
                    f"task's horizon of {self.horizon} steps (a shorter time limit?); such episodes are not kept "
                    "as safe demonstrations (DemoRecorder.left_out lists their lengths; horizon=... sets another rule)",
                    UserWarning,
                    stacklevel=2,
                )
            self.left_out.append(len(rewards))
            return False
        self.candidates.append((np.stack(observations), np.stack(actions), np.asarray(rewards), crashed))
        self.sources.append(k)
        return crashed

    @property
    def group_sizes(self) -> tuple[int, int]:
        """``(safe, unsafe)`` candidates so far."""
        unsafe = sum(c[3] for c in self.candidates)
        return len(self.candidates) - unsafe, unsafe

    def enough(self, n_safe: int, n_unsafe: int) -> bool:
        safe, unsafe = self.group_sizes
        return safe >= n_safe and unsafe >= n_unsafe

    def select(self, n_safe: int, n_unsafe: int, *, provenance: str | None = None) -> EpisodeSet:
        """``n_safe`` safe and ``n_unsafe`` unsafe demonstrations at evenly spaced positions of
        the candidates, in the order they were recorded."""
        n_safe = whole("n_safe", n_safe, 1, I64_MAX)
        n_unsafe = whole("n_unsafe", n_unsafe, 1, I64_MAX)
        safe, unsafe = self.group_sizes
        if safe < n_safe or unsafe < n_unsafe:
            raise DefenderError(
                f"select: {safe} safe and {unsafe} unsafe candidates, asked for {n_safe} and {n_unsafe} "
                "(at least 1 of each): record more episodes or ask for fewer"
            )
        by_group = lambda c: [i for i, e in enumerate(self.candidates) if e[3] == c]  # noqa: E731
        chosen = sorted(spread(by_group(False), n_safe) + spread(by_group(True), n_unsafe))
        meta = {
            "provenance": provenance
            or f"defender_rl.DemoRecorder (seed {self.seed}): one episode of the policy after each "
            f"training episode ({len(self.candidates)} candidates)",
            "selection": "per group, evenly spaced positions (first and last included) among the candidates in order",
            "source_training_episodes": [self.sources[i] for i in chosen],
        }
        return EpisodeSet.from_episodes([self.candidates[i] for i in chosen], env_id=self.env_id, meta=meta)


def collect_demos(
    env: gym.Env | str,
    policy: Callable[[np.ndarray], Any],
    n_safe: int,
    n_unsafe: int,
    *,
    train: Callable[[int], None] | None = None,
    max_episodes: int = 10_000,
    seed: int = 0,
    horizon: int | None = None,
) -> EpisodeSet:
    """The paper's procedure around a training loop of your own: for ``k = 0, 1, ...`` call
    ``train(k)`` (run one training episode of your agent; None for a fixed policy), then record
    one episode of ``policy``; stop once both groups have enough candidates and select
    ``n_safe`` + ``n_unsafe`` demonstrations (see :class:`DemoRecorder`: a safe one reached the
    task's horizon, or ``horizon`` steps when given)."""
    n_safe = whole("n_safe", n_safe, 1, I64_MAX)
    n_unsafe = whole("n_unsafe", n_unsafe, 1, I64_MAX)
    max_episodes = whole("max_episodes", max_episodes, 1, I64_MAX)
    # Each training episode records one candidate: a request that cannot be met is refused
    # before the training, not after max_episodes of it.
    if n_safe + n_unsafe > max_episodes:
        raise DefenderError(
            f"collect_demos: n_safe + n_unsafe = {n_safe + n_unsafe} exceeds max_episodes = {max_episodes} "
            "(each training episode records one candidate); raise max_episodes or ask for fewer"
        )
    recorder = DemoRecorder(env, seed=seed, horizon=horizon)
    for k in range(max_episodes):
        if train is not None:
            train(k)
        recorder.record(policy, after_episode=k)
        if recorder.enough(n_safe, n_unsafe):
            return recorder.select(n_safe, n_unsafe)
    safe, unsafe = recorder.group_sizes
    left_out = (
        f"; {len(recorder.left_out)} episodes ended before the horizon of {recorder.horizon} steps without "
        "terminating and were not kept (horizon=... sets another rule)"
        if recorder.left_out
        else ""
    )
    raise DefenderError(
        f"collect_demos: after {max_episodes} episodes only {safe} safe and {unsafe} unsafe candidates "
        f"(asked {n_safe} and {n_unsafe}); raise max_episodes or ask for fewer{left_out}"
    )
