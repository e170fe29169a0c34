"""The offline ablation (SPEC section 7) spread over a Ray cluster.

``defender ablate`` and :func:`defender_rl.ablate` replay every recorded episode against every
strategy on the cores of one machine. The ``Equal`` window costs O(n^3) per episode of n steps,
so the ablation of a long run's episodes with all 576 strategies is hours of one machine. Here
the episodes of each task are split into parts of about equal cost, each part is one Ray task
with ``{"cpu": 1}`` running the same Rust ablation on one thread, and the parts are merged::

    import ray
    from defender_rl.ray_ablation import ablate_on_ray

    ray.init()                                  # or ray.init(address="auto") on a cluster
    rows = ablate_on_ray(
        [("data/demos/Hopper-v5.npz", "hopper-episodes.npz"),
         ("data/demos/Walker2d-v5.npz", "walker-episodes.npz")],
        out="scores.csv",                       # SPEC section 9's CSV, as `defender ablate` writes
    )

The merge is exact: a strategy's score is ``mean_e(ratio_e) * count(safe_e) / |E|``, both means
over episodes, so the means of disjoint parts weighted by their episode counts are the means of
the whole (to the last bits of floating point). Several tasks are ranked by the mean over tasks,
as ``defender ablate`` ranks them (``defender::rank_tasks``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any, Sequence


from ._core import EpisodeSet, ablate
from ._core import strategies as all_strategies

__all__ = ["ablate_on_ray", "split_episodes"]

CSV_HEADER = "rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score"


def _episode_set(x: EpisodeSet | str | os.PathLike[str], what: str) -> EpisodeSet:
    if isinstance(x, EpisodeSet):
        return x
    if isinstance(x, (str, os.PathLike)):
        return EpisodeSet.load(os.fspath(x))
    raise TypeError(f"{what}: expected an EpisodeSet or the path of an .npz file, got {type(x).__name__}")


def split_episodes(episodes: EpisodeSet, parts: int, *, cost_power: int = 3) -> list[EpisodeSet]:
    """``episodes`` in at most ``parts`` disjoint sets of about equal replay cost (an episode of n
    steps costs ``n ** cost_power``: 3 when the ``Equal`` window is scored, 1 otherwise), longest
    first onto the least loaded part. Every episode is in exactly one part, in file order within
    it; empty parts are dropped."""
    if parts < 1:
        raise ValueError(f"parts: {parts}; give at least 1")
    lengths = [len(episodes.episode(i)["rew"]) for i in range(len(episodes))]
    loads = [0.0] * parts
    members: list[list[int]] = [[] for _ in range(parts)]
    for i in sorted(range(len(lengths)), key=lambda i: (-lengths[i], i)):
        p = min(range(parts), key=lambda p: (loads[p], p))
        members[p].append(i)
        loads[p] += float(lengths[i]) ** cost_power
    return [_subset(episodes, sorted(idx)) for idx in members if idx]


def _subset(episodes: EpisodeSet, idx: Sequence[int]) -> EpisodeSet:
    """The episodes ``idx`` of ``episodes``, in that order, with its metadata."""
    return EpisodeSet.from_episodes([episodes.episode(i) for i in idx], meta=episodes.meta)


def _merge_parts(parts: Sequence[tuple[int, dict[str, Any]]]) -> dict[str, tuple[float, float]]:
    """One task's (mean_ratio, safe_rate) per strategy from its parts' ablations, each weighted by
    its number of episodes."""
    total = sum(n for n, _ in parts)
    sums: dict[str, list[float]] = {}
    for n, table in parts:
        for name, ratio, safe in zip(table["strategy"], table["mean_ratio"], table["safe_rate"]):
            acc = sums.setdefault(str(name), [0.0, 0.0])
            acc[0] += n * float(ratio)
            acc[1] += n * float(safe)
    return {name: (r / total, s / total) for name, (r, s) in sums.items()}


def _rank(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Highest score first, ties by name (SPEC section 7); ranks from 1."""
    rows.sort(key=lambda r: (-r["score"], r["strategy"]))
    for i, r in enumerate(rows):
        r["rank"] = i + 1
    return rows


def _write_csv(path: str | os.PathLike[str], rows: list[dict[str, Any]]) -> None:
    """SPEC section 9's CSV, written atomically (a temporary file renamed over ``path``)."""
    path = Path(path)
    lines = [CSV_HEADER] + [
        f"{r['rank']},{r['strategy']},{r['safe']},{r['unsafe']},{r['mode']},"
        f"{r['mean_ratio']!r},{r['safe_rate']!r},{r['score']!r}"
        for r in rows
    ]
    fd, tmp = tempfile.mkstemp(dir=path.parent or ".", prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write("\n".join(lines) + "\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def ablate_on_ray(
    tasks: Sequence[tuple[EpisodeSet | str | os.PathLike[str], EpisodeSet | str | os.PathLike[str]]],
    *,
    mode: str = "state",
    strategies: Sequence[str] | None = None,
    no_equal: bool = False,
    num_demos: int | None = None,
    parts_per_task: int | None = None,
    out: str | os.PathLike[str] | None = None,
) -> list[dict[str, Any]]:
    """Ranks strategies by the offline ablation over ``tasks`` (``(demos, episodes)`` pairs, each
    an :class:`EpisodeSet` or an ``.npz`` path), one Ray task per part of each task's episodes.

    - ``mode``: ``"state"`` or ``"state-action"``.
    - ``strategies``: names (``"MeanDemoW5/MeanDemoW10"``); ``None``: all 576.
    - ``no_equal``: leave out the strategies with an ``Equal`` window (as ``--no-equal``).
    - ``num_demos``: the first N demonstrations of each group (as ``--num-demos``).
    - ``parts_per_task``: how many parts each task's episodes are split into; ``None``: the
      cluster's CPUs (``ray.cluster_resources()["CPU"]``), so one task alone fills the cluster.
    - ``out``: also write SPEC section 9's CSV there.

    Returns the rows as :func:`defender_rl.ablate` does (``rank``, ``strategy``, ``safe``,
    ``unsafe``, ``mode``, ``mean_ratio``, ``safe_rate``, ``score``), best first; with several
    tasks, each number is the mean over tasks. Call ``ray.init(...)`` first to choose the cluster
    (a local one is started otherwise). Bad input raises before any task is sent.
    """
    import ray

    if not tasks:
        raise ValueError("tasks: empty; give at least one (demos, episodes) pair")
    names = list(all_strategies()) if strategies is None else [str(s) for s in strategies]
    if no_equal:
        names = [n for n in names if "Equal" not in n]
    if not names:
        raise ValueError("no strategy left to score")
    loaded = []
    for t, pair in enumerate(tasks):
        if len(pair) != 2:
            raise ValueError(f"tasks[{t}]: expected a (demos, episodes) pair, got {len(pair)} items")
        demos = _episode_set(pair[0], f"tasks[{t}] demos")
        if num_demos is not None:
            demos = demos.select_demos(num_demos)
        episodes = _episode_set(pair[1], f"tasks[{t}] episodes")
        # Checks the names, the mode and the pair's dimensions here, on one short episode, so
        # that bad input fails before the cluster works for hours.
        shortest = min(range(len(episodes)), key=lambda i: len(episodes.episode(i)["rew"]))
        ablate(demos, _subset(episodes, [shortest]), mode, names, True, 1)
        loaded.append((demos, episodes))
    if not ray.is_initialized():
        ray.init()
    parts = parts_per_task or max(1, int(ray.cluster_resources().get("CPU", 1)))
    power = 3 if any("Equal" in n for n in names) else 1

    @ray.remote(num_cpus=1)
    def _part(demos: EpisodeSet, episodes: EpisodeSet) -> tuple[int, dict[str, Any]]:
        return len(episodes), ablate(demos, episodes, mode, names, True, 1)

    futures = []
    for demos, episodes in loaded:
        demos_ref = ray.put(demos)
        futures.append([_part.remote(demos_ref, p) for p in split_episodes(episodes, parts, cost_power=power)])
    per_task = [_merge_parts(ray.get(f)) for f in futures]

    rows = []
    for name in names:
        ratio = sum(task[name][0] for task in per_task) / len(per_task)
        safe = sum(task[name][1] for task in per_task) / len(per_task)
        score = sum(task[name][0] * task[name][1] for task in per_task) / len(per_task)
        safe_method, unsafe_method = name.split("/")
        rows.append(
            {"rank": 0, "strategy": name, "safe": safe_method, "unsafe": unsafe_method, "mode": mode,
             "mean_ratio": ratio, "safe_rate": safe, "score": score}
        )
    rows = _rank(rows)
    if out is not None:
        _write_csv(out, rows)
    return rows
