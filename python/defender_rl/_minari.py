"""Minari datasets as episode sets (`EpisodeSet.from_minari`, `defender_rl.from_minari`)."""

from __future__ import annotations

from typing import Any, Callable, Iterable

import numpy as np

from ._core import DefenderError, EpisodeSet


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
) -> EpisodeSet:
    """Turns a Minari dataset's episodes into an episode set (demonstrations or recorded
    episodes).

    Args:
        dataset: a ``minari.MinariDataset`` (``minari.load_dataset(...)``), or a dataset id
            string, loaded with ``minari.load_dataset`` (locally; nothing is downloaded).
        crashed: a function of a Minari ``EpisodeData`` that says whether the episode is unsafe;
            by default an episode is unsafe when it ended by termination (``terminations[-1]``),
            as SPEC section 6 and ``defender demos collect`` decide.
        env_id: the Gymnasium id written into ``meta``; by default the dataset's
            ``env_spec.id``.
        episode_indices: which episodes to take (all by default).
    """
    if isinstance(dataset, str):
        import minari

        dataset = minari.load_dataset(dataset)
    if env_id is None:
        spec = getattr(dataset, "env_spec", None)
        env_id = getattr(spec, "id", None)
    episodes = []
    source = dataset.iterate_episodes(episode_indices) if episode_indices is not None else dataset.iterate_episodes()
    for k, ep in enumerate(source):
        obs = _flat(ep.observations, "observations", k)
        act = _flat(ep.actions, "actions", k)
        rew = np.asarray(ep.rewards, dtype=np.float64).reshape(-1)
        if len(rew) == 0:
            continue  # an episode with no transition carries nothing to compare
        is_crash = bool(np.asarray(ep.terminations)[-1]) if crashed is None else bool(crashed(ep))
        episodes.append((obs, act, rew, is_crash))
    if not episodes:
        raise DefenderError("from_minari: the dataset has no episode with at least one transition")
    meta = {"provenance": f"minari dataset {getattr(dataset, 'spec', None) and dataset.spec.dataset_id}"}
    if crashed is None:
        meta["crashed_rule"] = "the episode's last step terminated"
    else:
        meta["crashed_rule"] = f"user function {getattr(crashed, '__name__', repr(crashed))}"
    return EpisodeSet.from_episodes(episodes, env_id=env_id, meta=meta)
