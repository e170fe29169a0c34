"""Minari datasets as episode sets (`EpisodeSet.from_minari`, `defender_rl.from_minari`)."""

from __future__ import annotations

from typing import Any, Callable, Iterable

import numpy as np

from ._core import DefenderError, EpisodeSet
from .horizon import task_horizon, warn_left_out


def _flat(x: Any, what: str, index: int) -> np.ndarray:
    if isinstance(x, dict):
        raise DefenderError(
            f"episode {index}: {what} is a dict (a Dict space); only 1-D Box spaces make episode sets"
        )
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise DefenderError(f"episode {index}: {what} has shape {a.shape}, expected [steps, dim]")
    return a


def from_minari(
    dataset: Any,
    *,
    crashed: Callable[[Any], bool] | None = None,
    env_id: str | None = None,
    episode_indices: Iterable[int] | None = None,
    horizon: int | None = None,
) -> EpisodeSet:
    """Turns a Minari dataset's episodes into an episode set (demonstrations or recorded
    episodes).

    The rule, by default: an episode is **unsafe** when it ended by termination
    (``terminations[-1]``: the task's own failure, as SPEC section 6 and ``defender demos
    collect`` decide), and **safe** when it reached the task's horizon without terminating (a
    time-limit truncation after ``horizon`` steps: the ``max_episode_steps`` Gymnasium registers
    for ``env_id``, else the dataset's own). An episode that did neither (cut earlier by a
    collector's own limit) is left out, with a warning naming how many and their lengths: it
    did not crash, but shows less than a whole episode of the task. With ``crashed`` given, that
    function decides and every other episode is safe, whatever its length.

    Args:
        dataset: a ``minari.MinariDataset`` (``minari.load_dataset(...)``), or a dataset id
            string, loaded with ``minari.load_dataset`` (locally; nothing is downloaded).
        crashed: a function of a Minari ``EpisodeData`` that says whether the episode is unsafe
            (your rule instead of the default above).
        env_id: the Gymnasium id written into ``meta``; by default the dataset's
            ``env_spec.id``.
        episode_indices: which episodes to take (all by default).
        horizon: the task's horizon in steps for the default rule (default: see above).
    """
    if isinstance(dataset, str):
        import minari

        dataset = minari.load_dataset(dataset)
    if env_id is None:
        spec = getattr(dataset, "env_spec", None)
        env_id = getattr(spec, "id", None)
    if horizon is None:
        spec = getattr(dataset, "env_spec", None)
        horizon = task_horizon(env_id, getattr(spec, "max_episode_steps", None))
    episodes, left_out = [], []
    source = dataset.iterate_episodes(episode_indices) if episode_indices is not None else dataset.iterate_episodes()
    for k, ep in enumerate(source):
        obs = _flat(ep.observations, "observations", k)
        act = _flat(ep.actions, "actions", k)
        rew = np.asarray(ep.rewards, dtype=np.float64).reshape(-1)
        if len(rew) == 0:
            continue  # an episode with no transition carries nothing to compare
        if crashed is None:
            is_crash = bool(np.asarray(ep.terminations)[-1])
            if not is_crash and horizon is not None and len(rew) < horizon:
                left_out.append(len(rew))
                continue
        else:
            is_crash = bool(crashed(ep))
        episodes.append((obs, act, rew, is_crash))
    warn_left_out("from_minari", left_out, horizon)
    if not episodes:
        raise DefenderError("from_minari: the dataset has no episode with at least one transition")
    meta = {"provenance": f"minari dataset {getattr(dataset, 'spec', None) and dataset.spec.dataset_id}"}
    if crashed is None:
        meta["crashed_rule"] = "the episode's last step terminated"
        meta["safe_rule"] = f"reached the task's horizon of {horizon} steps without terminating"
    else:
        meta["crashed_rule"] = f"user function {getattr(crashed, '__name__', repr(crashed))}"
    return EpisodeSet.from_episodes(episodes, env_id=env_id, meta=meta)
