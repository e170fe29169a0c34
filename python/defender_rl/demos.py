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

On a task whose safety is a per-step cost (Safety-Gymnasium's), ``episode_cost_limit=L`` labels
by docs/SPEC.md section 13's rule instead, as ``defender demos collect`` does there (the Rust
``ViolationTracker``, crates/defender/src/violation.rs): an episode is unsafe once its summed
cost passes ``L`` (strictly above), and its demonstration stops on that step; safe when it
reaches the horizon with cost ``<= L``; one the environment ends earlier under the limit (a fall)
is neither and is dropped. The set's ``meta`` then carries ``episode_cost_limit``, which
``DefenderWrapper`` and ``defender train`` check against their own limit.

Reset seeds: episode ``k`` resets with :func:`reset_seed` (``derive_seed(seed, "demonstration",
k)`` folded to 32 bits, high half XOR low half), because Safety-Gymnasium's layout sampling (a
``numpy.random.RandomState``) refuses seeds of 2**32 and above, and every Gymnasium environment
takes a 32-bit one. The command line keeps the 64-bit seed: its MuJoCo tasks seed a ChaCha8 RNG
with it, so its recorded sets stay what they were.

:class:`DemoRecorder` does the recording and the selection for any policy callable on any
Gymnasium environment; ``defender_rl.sb3.DemoCollectorCallback`` drives it from an SB3 agent's
training loop, and :func:`collect_demos` from a loop of your own.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Callable, Mapping

import gymnasium as gym
import numpy as np

from ._args import I64_MAX, U64_MAX, whole
from ._core import DefenderError, EpisodeSet, derive_seed
from .horizon import env_horizon

#: The ``meta`` key of a set labelled by an episode cost limit (crates/defender's
#: ``EPISODE_COST_LIMIT_KEY``).
EPISODE_COST_LIMIT_KEY = "episode_cost_limit"


def fold32(seed: int) -> int:
    """A 64-bit seed reduced to 32 bits: its high half XOR its low half. ``derive_seed``'s
    output is already well mixed (splitmix64's finaliser), so either half would do; the XOR keeps
    every input bit in play and is one line to reproduce in any language."""
    seed = int(seed)
    return (seed ^ (seed >> 32)) & 0xFFFF_FFFF


def reset_seed(seed: int, k: int) -> int:
    """The seed the demonstration after training episode ``k`` resets with:
    ``fold32(derive_seed(seed, "demonstration", k))``, a 32-bit seed every Gymnasium and
    Safety-Gymnasium environment accepts."""
    return fold32(derive_seed(seed, "demonstration", k))


def rust_float(x: float) -> str:
    """``x`` as Rust's ``{}`` writes an f64 (25.0 as "25"), so that the provenance reads as the
    command line's."""
    return str(int(x)) if x.is_integer() and abs(x) < 1e16 else repr(x)


def check_limit(limit: Any) -> float | None:
    """``episode_cost_limit`` as ``UnsafeRule::from_limit`` takes it: None, or a finite number > 0."""
    if limit is None:
        return None
    if isinstance(limit, (bool, np.bool_)) or not isinstance(limit, (int, float, np.integer, np.floating)):
        raise TypeError(f"episode_cost_limit must be a number or None, got {limit!r}")
    limit = float(limit)
    if not (math.isfinite(limit) and limit > 0):
        raise DefenderError(
            f"episode_cost_limit = {limit}: it must be a finite number > 0 (an episode is unsafe once its "
            "cost passes it; Safety-Gymnasium's limit is 25)"
        )
    return limit


def own_time_limit(env: gym.Env) -> int | None:
    """The time limit the environment itself applies (a ``TimeLimit`` wrapper, else its spec's
    ``max_episode_steps``), if any."""
    e = env
    while isinstance(e, gym.Wrapper):
        # Gymnasium's TimeLimit, or one with its attribute (Safety-Gymnasium's SafeTimeLimit).
        limit = getattr(e, "_max_episode_steps", None)
        if isinstance(e, gym.wrappers.TimeLimit) or isinstance(limit, (int, np.integer)):
            return int(limit)
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
            a Gymnasium id for ``gymnasium.make`` (Safety-Gymnasium's Gymnasium-API ids, such as
            ``"SafetyPointGoal1Gymnasium-v0"``, once ``safety_gymnasium`` is imported).
        seed: the demonstration after training episode ``k`` resets with
            :func:`reset_seed` ``(seed, k)``: ``derive_seed(seed, "demonstration", k)``, as
            ``defender demos collect`` derives it, folded to 32 bits.
        max_steps: a cap on the length of one recorded episode (the environment's own time limit
            applies first).
        horizon: the length a safe episode reaches; default: the task's horizon (the
            ``max_episode_steps`` Gymnasium registers for the environment's id, else its own time
            limit); 0 counts every episode that did not terminate (or pass the cost limit) as safe.
        episode_cost_limit: on a task whose safety is a per-step cost, label by docs/SPEC.md
            section 13: unsafe once the episode's summed cost passes this limit (the
            demonstration ends on that step), safe when it reaches the horizon within it,
            dropped when the environment ends it earlier under it. None (the default): the crash
            rule (unsafe = terminated); costs are not read.
        cost_key: the key of the step ``info`` that holds the step's cost (``"cost"``, where
            Safety-Gymnasium's Gymnasium-API conversion puts it); read only with
            ``episode_cost_limit``, and then required on every step.
    """

    def __init__(
        self,
        env: gym.Env | str,
        *,
        seed: int = 0,
        max_steps: int = 100_000,
        horizon: int | None = None,
        episode_cost_limit: float | None = None,
        cost_key: str = "cost",
    ):
        self.seed = whole("seed", seed, 0, U64_MAX)
        self.max_steps = whole("max_steps", max_steps, 1, I64_MAX)
        horizon = whole("horizon", horizon, 0, I64_MAX, optional=True)
        self.episode_cost_limit = check_limit(episode_cost_limit)
        if not isinstance(cost_key, str):
            raise TypeError(f"cost_key must be a string (a key of the step's info), got {cost_key!r}")
        self.cost_key = cost_key
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

    def _cost(self, info: Any, step: int) -> float:
        """The step's cost from ``info[cost_key]``, checked as ``DefenderWrapper`` checks it."""
        key = self.cost_key
        if not isinstance(info, Mapping) or key not in info:
            keys = sorted(map(str, info)) if isinstance(info, Mapping) else f"none: it is a {type(info).__name__}"
            raise DefenderError(
                f"DemoRecorder(episode_cost_limit={rust_float(self.episode_cost_limit)}): step {step}'s info has no "
                f"{key!r} (cost_key; its keys: {keys}); pass the key under which the environment's info carries "
                "the step's cost, or leave episode_cost_limit out for the crash rule"
            )
        value = info[key]
        try:
            if isinstance(value, (str, bytes)):
                raise TypeError
            cost = float(value)
        except (TypeError, ValueError):
            raise TypeError(f"DemoRecorder: the cost info[{key!r}] at step {step} is not a number: {value!r}") from None
        if not (math.isfinite(cost) and cost >= 0.0):
            raise DefenderError(
                f"DemoRecorder: the cost info[{key!r}] at step {step} is {cost}; a cost must be a finite number >= 0"
            )
        return cost

    def record(self, policy: Callable[[np.ndarray], Any], after_episode: int | None = None) -> bool:
        """Runs one episode of ``policy(obs) -> action`` and keeps it as a candidate (unless it is
        of neither group: it ended before the horizon without a crash, or without passing the
        cost limit; then it is left out and its length counted in ``left_out``). Returns whether
        it is unsafe (crashed, or passed ``episode_cost_limit``)."""
        k = len(self.sources) if after_episode is None else int(after_episode)
        obs, _ = self.env.reset(seed=reset_seed(self.seed, k))
        observations, actions, rewards = [np.asarray(obs, dtype=np.float64)], [], []
        limit, total = self.episode_cost_limit, 0.0
        unsafe = terminated = False
        for _ in range(self.max_steps):
            action = np.asarray(policy(obs), dtype=np.float64)
            obs, reward, terminated, truncated, info = self.env.step(action)
            observations.append(np.asarray(obs, dtype=np.float64))
            actions.append(action)
            rewards.append(float(reward))
            if limit is None:
                unsafe = bool(terminated)  # SPEC section 6: the crash
            else:
                # SPEC section 13 (ViolationTracker::step): costs summed in step order, in f64;
                # the step that passes the limit is the demonstration's last.
                total += self._cost(info, len(rewards))
                unsafe = total > limit
            if unsafe or terminated or truncated:
                break
        # Neither group: an end before the horizon without a violation (a shorter time limit,
        # or on a cost task the environment's own termination, a fall that costs nothing).
        if not unsafe and (terminated or (self.horizon and len(rewards) < self.horizon)):
            if not self.left_out:
                why = (
                    f"the environment terminated an episode after {len(rewards)} steps with cost {total:g}, "
                    f"within the limit of {rust_float(limit)}: it is neither unsafe nor safe (docs/SPEC.md, "
                    "section 13), so it is not kept"
                    if terminated
                    else f"an episode ended after {len(rewards)} steps without "
                    + ("terminating" if limit is None else "passing the cost limit")
                    + f", before the task's horizon of {self.horizon} steps (a shorter time limit?); such episodes "
                    "are not kept as safe demonstrations"
                )
                warnings.warn(
                    f"DemoRecorder: {why} (DemoRecorder.left_out lists the lengths of those left out; "
                    "horizon=... sets another rule)",
                    UserWarning,
                    stacklevel=2,
                )
            self.left_out.append(len(rewards))
            return False
        self.candidates.append((np.stack(observations), np.stack(actions), np.asarray(rewards), unsafe))
        self.sources.append(k)
        return unsafe

    @property
    def group_sizes(self) -> tuple[int, int]:
        """``(safe, unsafe)`` candidates so far."""
        unsafe = sum(c[3] for c in self.candidates)
        return len(self.candidates) - unsafe, unsafe

    def enough(self, n_safe: int, n_unsafe: int) -> bool:
        safe, unsafe = self.group_sizes
        return safe >= n_safe and unsafe >= n_unsafe

    def select(
        self,
        n_safe: int,
        n_unsafe: int,
        *,
        provenance: str | None = None,
        training_steps: int | None = None,
        learning_starts: int | None = None,
    ) -> EpisodeSet:
        """``n_safe`` safe and ``n_unsafe`` unsafe demonstrations at evenly spaced positions of
        the candidates, in the order they were recorded. ``meta`` holds what ``defender demos
        collect`` writes: ``provenance``, ``selection``, ``source_training_episodes``, the
        dimensions, ``episode_cost_limit`` on a cost rule, and ``training_steps`` /
        ``learning_starts`` when given (the recorder does not see the training)."""
        n_safe = whole("n_safe", n_safe, 1, I64_MAX)
        n_unsafe = whole("n_unsafe", n_unsafe, 1, I64_MAX)
        training_steps = whole("training_steps", training_steps, 0, U64_MAX, optional=True)
        learning_starts = whole("learning_starts", learning_starts, 0, U64_MAX, optional=True)
        safe, unsafe = self.group_sizes
        if safe < n_safe or unsafe < n_unsafe:
            raise DefenderError(
                f"select: {safe} safe and {unsafe} unsafe candidates, asked for {n_safe} and {n_unsafe} "
                "(at least 1 of each): record more episodes or ask for fewer"
            )
        by_group = lambda c: [i for i, e in enumerate(self.candidates) if e[3] == c]  # noqa: E731
        chosen = sorted(spread(by_group(False), n_safe) + spread(by_group(True), n_unsafe))
        limit = self.episode_cost_limit
        # The command line's wording of its rule (crates/defender-cli/src/commands/demos/spec.rs).
        labels = (
            "unsafe: terminated before the horizon"
            if limit is None
            else f"unsafe: cut on the step where the episode cost passed {rust_float(limit)}; safe: reached the "
            f"horizon with cost <= {rust_float(limit)}; episodes that ended early under the limit were dropped"
        )
        first_obs, first_act = self.candidates[chosen[0]][0], self.candidates[chosen[0]][1]
        meta: dict[str, Any] = {
            "obs_dim": int(first_obs.shape[1]),
            "act_dim": int(first_act.shape[1]),
            "provenance": provenance
            or f"defender_rl.DemoRecorder (seed {self.seed}): one episode of the policy after each "
            f"training episode ({len(self.candidates)} candidates; {labels})",
            "selection": "per group, evenly spaced positions (first and last included) among the candidates in order",
            "source_training_episodes": [self.sources[i] for i in chosen],
        }
        if limit is not None:
            # What makes these demonstrations unsafe: a run checks it against its own rule.
            meta[EPISODE_COST_LIMIT_KEY] = limit
        if training_steps is not None:
            meta["training_steps"] = training_steps
        if learning_starts is not None:
            meta["learning_starts"] = learning_starts
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
    episode_cost_limit: float | None = None,
    cost_key: str = "cost",
) -> EpisodeSet:
    """The paper's procedure around a training loop of your own: for ``k = 0, 1, ...`` call
    ``train(k)`` (run one training episode of your agent; None for a fixed policy), then record
    one episode of ``policy``; stop once both groups have enough candidates and select
    ``n_safe`` + ``n_unsafe`` demonstrations (see :class:`DemoRecorder`: a safe one reached the
    task's horizon, or ``horizon`` steps when given; with ``episode_cost_limit``, unsafe ones
    passed that episode cost and stop on the step that passed it, docs/SPEC.md section 13)."""
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
    recorder = DemoRecorder(env, seed=seed, horizon=horizon, episode_cost_limit=episode_cost_limit, cost_key=cost_key)
    for k in range(max_episodes):
        if train is not None:
            train(k)
        recorder.record(policy, after_episode=k)
        if recorder.enough(n_safe, n_unsafe):
            return recorder.select(n_safe, n_unsafe)
    safe, unsafe = recorder.group_sizes
    left_out = (
        f"; {len(recorder.left_out)} episodes were of neither group (they ended before the horizon of "
        f"{recorder.horizon} steps without a violation) and were not kept (horizon=... sets another rule)"
        if recorder.left_out
        else ""
    )
    raise DefenderError(
        f"collect_demos: after {max_episodes} episodes only {safe} safe and {unsafe} unsafe candidates "
        f"(asked {n_safe} and {n_unsafe}); raise max_episodes or ask for fewer{left_out}"
    )
