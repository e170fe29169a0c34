"""DEFENDER for Python: DTW-based episode filtering using demonstrations, on a Rust core.

During training, the trajectory so far is compared by DTW with safe and unsafe demonstrations;
when it looks more like the unsafe ones the action is not executed, the episode ends with
``R_task`` and a learned dynamics model supplies the next observation. Any agent (SB3, CleanRL,
your own) trains on :class:`DefenderWrapper` unchanged.

Everything DEFENDER decides is computed by the Rust crate ``defender`` (the code of the
``defender`` command line), reached through the extension ``defender_rl._core``.
"""

from __future__ import annotations

from ._core import (
    DefenderError,
    EpisodeSet,
    ResetNeeded,
    __version__,
    ablate,
    derive_seed,
    dtw,
    select,
    group_cost,
    strategies,
    trajectory_costs,
    window_cost,
)
from ._minari import from_minari
from .demos import DemoRecorder, collect_demos
from .wrapper import DefenderWrapper

__all__ = [
    "DefenderError",
    "DefenderWrapper",
    "DemoRecorder",
    "EpisodeSet",
    "ResetNeeded",
    "__version__",
    "ablate",
    "collect_demos",
    "derive_seed",
    "dtw",
    "from_minari",
    "group_cost",
    "select",
    "strategies",
    "trajectory_costs",
    "window_cost",
]
