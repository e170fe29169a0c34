"""The task's horizon and the safe demonstrations measured against it.

DEFENDER's safe group stands for "what a run that does not crash looks like" on the task being
trained. An episode cut short by a time limit of its own (``gym.make(ENV_ID,
max_episode_steps=40)``, a data collector's cap) did not crash, but it never showed the long
stretch a 1,000-step Hopper-v5 episode needs, so by default it is not a safe demonstration: an
episode is safe when it reached the task's horizon (the ``max_episode_steps`` Gymnasium registers
for the task) without terminating. Sets made elsewhere are checked when loaded into a
:class:`~defender_rl.DefenderWrapper` (a warning names how many safe episodes are shorter and
their lengths).
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym


def task_horizon(env_id: str | None, fallback: int | None = None) -> int | None:
    """The horizon Gymnasium registers for ``env_id`` (its ``max_episode_steps``), else
    ``fallback``. The registered value, not a ``max_episode_steps`` given to one ``gym.make``:
    that is the task the demonstrations are compared with."""
    if env_id:
        try:
            registered = gym.spec(env_id).max_episode_steps
        except gym.error.Error:
            registered = None
        if registered:
            return int(registered)
    return int(fallback) if fallback else None


def env_horizon(env: gym.Env) -> int | None:
    """The task horizon of a built environment: its registered one, else its own time limit."""
    spec = env.spec
    return task_horizon(spec.id if spec is not None else None, spec.max_episode_steps if spec is not None else None)


def _lengths(lengths: list[int]) -> str:
    shown = ", ".join(str(n) for n in sorted(lengths)[:10])
    return shown + (", ..." if len(lengths) > 10 else "")


def short_safe_episodes(demos: Any, horizon: int | None, num_demos: int | None = None) -> list[int]:
    """Lengths of the safe episodes of ``demos`` (an :class:`~defender_rl.EpisodeSet`; the first
    ``num_demos`` safe ones when given, as the wrapper uses them) shorter than ``horizon``."""
    if not horizon:
        return []
    short, used = [], 0
    for i in range(len(demos)):
        e = demos.episode(i)
        if e["crashed"]:
            continue
        used += 1
        if num_demos is not None and used > num_demos:
            break
        if len(e["rew"]) < horizon:
            short.append(len(e["rew"]))
    return short


def warn_short_safe(demos: Any, horizon: int | None, what: str, num_demos: int | None = None, stacklevel: int = 3) -> None:
    """Warns when safe episodes of ``demos`` end before ``horizon``, naming how many and their
    lengths."""
    short = short_safe_episodes(demos, horizon, num_demos)
    if short:
        warnings.warn(
            f"{what}: {len(short)} safe demonstration(s) end before the task's horizon of {horizon} steps "
            f"(lengths {_lengths(short)}): they did not crash, but show less than a whole episode of the task. "
            "Record safe demonstrations that reach the horizon (a time-limit truncation at the task's "
            "max_episode_steps), or leave those out",
            UserWarning,
            stacklevel=stacklevel,
        )


def demos_horizon(demos: Any, num_demos: int | None = None) -> int | None:
    """The horizon the demonstrations were made with: their longest safe episode (the first
    ``num_demos`` safe ones when given), as the filter's own-episode rule reads it."""
    lengths, used = [], 0
    for i in range(len(demos)):
        e = demos.episode(i)
        if e["crashed"]:
            continue
        used += 1
        if num_demos is not None and used > num_demos:
            break
        lengths.append(len(e["rew"]))
    return max(lengths) if lengths else None


def warn_time_limit(env: gym.Env, demos: Any, what: str, num_demos: int | None = None, stacklevel: int = 3) -> None:
    """Warns when the wrapped environment's own time limit differs from the horizon the
    demonstrations were made with: its truncated episodes are then not what a safe one is."""
    limit = env.spec.max_episode_steps if env.spec is not None else None
    horizon = demos_horizon(demos, num_demos)
    if limit and horizon and int(limit) != horizon:
        effect = (
            "its episodes truncated before that are not safe and never join the safe group"
            if limit < horizon
            else "its episodes run longer than any safe demonstration"
        )
        warnings.warn(
            f"{what}: the wrapped environment's time limit (max_episode_steps={limit}) differs from the "
            f"horizon the demonstrations were made with ({horizon} steps, their longest safe episode): "
            f"{effect}. Use the task's own time limit, or demonstrations made with this one",
            UserWarning,
            stacklevel=stacklevel,
        )


def warn_left_out(what: str, lengths: list[int], horizon: int | None, stacklevel: int = 3) -> None:
    """Warns that episodes neither crashed nor reached the horizon and were left out."""
    if lengths:
        warnings.warn(
            f"{what}: left out {len(lengths)} episode(s) that neither terminated nor reached the task's "
            f"horizon of {horizon} steps (lengths {_lengths(lengths)}); pass a rule of your own to keep them",
            UserWarning,
            stacklevel=stacklevel,
        )
