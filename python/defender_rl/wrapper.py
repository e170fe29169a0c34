"""`DefenderWrapper`: DEFENDER as a Gymnasium wrapper (SPEC sections 4-6)."""

from __future__ import annotations

import json
import math
import os
import pickle
import sys
import time
import warnings
from typing import Any, Mapping, SupportsFloat

import gymnasium as gym
import numpy as np

from ._core import Core, DefenderError, EpisodeSet, profile_filter
from ._args import I64_MAX, U64_MAX, whole
from .horizon import env_horizon, warn_short_safe, warn_time_limit

#: The keys :class:`DefenderWrapper` adds to every step's ``info`` (flat scalars, so that SB3's
#: ``Monitor(info_keywords=...)`` and vector environments carry them).
INFO_KEYS = ("cost", "defender_filtered", "defender_safe_cost", "defender_unsafe_cost", "defender_outcome")

#: The keys of every step, also put into ``reset``'s ``info`` with these neutral values (a reset
#: takes no step: nothing was filtered, no DTW cost was computed, no safety cost was incurred),
#: so that a vector environment's ``info`` has them on every step whatever its autoreset mode
#: (under next-step autoreset, a sub-environment's ``info`` on the step that resets it is
#: ``reset``'s).
RESET_INFO = {
    "cost": 0.0,
    "defender_filtered": False,
    "defender_safe_cost": float("nan"),
    "defender_unsafe_cost": float("nan"),
}


class _DefaultCostKey(str):
    """The default ``cost_key``, ``"cost"``, told apart by identity from a ``"cost"`` the user
    passes: a key the user names must be in every step's ``info`` (else a typo would pass
    silently as "no violation"), while the default may be absent (then the crash rule)."""


_DEFAULT_COST_KEY = _DefaultCostKey("cost")

#: Episode statistics recorded *inside* DefenderWrapper miss the steps it filters (the wrapped
#: environment never sees them), so they describe another training than the one that runs.
_STATISTICS_WRAPPERS = (
    ("stable_baselines3.common.monitor", "Monitor", "Monitor(DefenderWrapper(env, ...))"),
    ("gymnasium.wrappers", "RecordEpisodeStatistics", "RecordEpisodeStatistics(DefenderWrapper(env, ...))"),
)
_warned_statistics: set[str] = set()


def _warn_statistics_inside(env: gym.Env) -> None:
    """Warns (once per class and process) when ``env`` holds an episode-statistics wrapper."""
    e = env
    while e is not None:
        for module, name, right in _STATISTICS_WRAPPERS:
            if any(c.__name__ == name and c.__module__.startswith(module.split(".")[0]) for c in type(e).__mro__):
                if name not in _warned_statistics:
                    _warned_statistics.add(name)
                    warnings.warn(
                        f"DefenderWrapper wraps a {name}: episodes DEFENDER ends by filtering never reach it, "
                        f"so its statistics (episode returns, lengths, counts) miss them. Put it outside: "
                        f"{right}. With Stable-Baselines3's make_vec_env, wrapper_class=DefenderWrapper puts its "
                        "Monitor inside; pass a function that builds the wrapper instead: "
                        "make_vec_env(lambda: DefenderWrapper(gym.make(ENV_ID), demos), n_envs=N) "
                        "(docs/python.md, 'Stable-Baselines3')",
                        UserWarning,
                        stacklevel=3,  # the caller of DefenderWrapper(...)
                    )
        e = getattr(e, "env", None) if isinstance(e, gym.Wrapper) else None


def _progress_on() -> bool:
    """Progress lines are on unless ``DEFENDER_PROGRESS_INTERVAL`` is ``off`` (as for the CLI)."""
    return os.environ.get("DEFENDER_PROGRESS_INTERVAL", "").strip().lower() not in ("off", "none")


def _say(line: str) -> None:
    """A progress line on stderr; a stderr that cannot be written loses it, nothing more."""
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _check_box(space: gym.Space, what: str) -> gym.spaces.Box:
    # Gymnasium flattens observations (FlattenObservation); actions have no such wrapper, and a
    # discrete action cannot feed DEFENDER's dynamics model: the advice differs.
    if what == "observation space":
        fix = "flatten it first (gymnasium.wrappers.FlattenObservation)"
    else:
        fix = ("DEFENDER needs continuous actions: a discrete or composite action space is not "
               "supported (wrap the environment so that it takes a 1-D float Box action)")
    if not isinstance(space, gym.spaces.Box):
        raise TypeError(f"DefenderWrapper needs a gymnasium.spaces.Box {what}, got {type(space).__name__} ({space}); {fix}")
    if len(space.shape) != 1:
        raise TypeError(f"DefenderWrapper needs a 1-D Box {what}, got shape {space.shape}; {fix}")
    if not np.issubdtype(space.dtype, np.floating):
        raise TypeError(f"DefenderWrapper needs a floating-point Box {what}, got dtype {space.dtype}")
    return space


def _dynamics_value(key: Any, value: Any) -> Any:
    """A ``dynamics`` value checked before it is sent on (so that the error names the key)."""
    where = f"dynamics[{key!r}]"
    if key == "background":
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{where} must be True or False, got {value!r}")
        return bool(value)
    if key == "hidden":
        if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
            raise TypeError(f"{where} must be a list of layer widths, got {value!r}")
        return [whole(f"{where}[{i}]", w, 1, I64_MAX) for i, w in enumerate(value)]
    if key in ("learning_rate", "error_ema_alpha"):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise TypeError(f"{where} must be a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise DefenderError(f"{where} must be a finite number, got {value!r}")
        return float(value)
    if key in ("batch_size", "buffer_size", "learning_starts", "train_freq", "gradient_steps"):
        return whole(where, value, 0, I64_MAX)
    # An unknown key: the Rust side names it and lists the known ones, whatever its value, so a
    # value JSON cannot carry (a numpy scalar, an object) goes as its text.
    return value if isinstance(value, (str, int, float, type(None))) else repr(value)


def _filter_values(filter: Mapping[str, Any]) -> dict:  # noqa: A002
    """``filter`` checked for types before it is sent on (the Rust side checks ranges)."""

    def number(where: str, value: Any) -> float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise TypeError(f"{where} must be a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise DefenderError(f"{where} must be a finite number, got {value!r}")
        return float(value)

    out: dict[str, Any] = {}
    for key, value in filter.items():
        where = f"filter[{key!r}]"
        if key == "margin":
            out[key] = number(where, value)
        elif key in ("budget", "own_episodes"):
            if not isinstance(value, Mapping):
                raise TypeError(f"{where} must be a dict, got {value!r}")
            inner: dict[str, Any] = {}
            for k, v in value.items():
                w = f"{where}[{k!r}]"
                inner[k] = number(w, v) if k == "share" else whole(w, v, 0, I64_MAX)
            out[key] = inner
        else:
            out[key] = value  # an unknown key: the Rust side names it and lists the known ones
    return out


class DefenderWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Wraps a Gymnasium environment with DEFENDER.

    At every step the trajectory element (``s_t``, or ``concat(s_t, a_t)`` with
    ``mode="state-action"``) goes to the online filter:

    * executed (``Safe(tau) < Unsafe(tau)``): the wrapped environment steps as usual, and the
      dynamics model learns from the real transition;
    * filtered: the wrapped environment is **not** stepped; the step returns the dynamics
      model's prediction as the observation, reward ``R_task``, ``terminated=True``.

    ``info`` gets ``cost`` (the step's safety cost, a float: see ``cost_key``),
    ``defender_filtered`` (bool), ``defender_safe_cost`` and
    ``defender_unsafe_cost`` (floats) on every step and, on the last step of an episode,
    ``defender_outcome``: ``"crashed"`` (the environment terminated it), ``"filtered"`` (DEFENDER
    ended it) or ``"truncated"`` (the time limit).

    The decision, costs, prediction, outcome and counters are computed by the Rust
    ``DefenderEnv`` (the code ``defender train`` runs), not re-implemented here.

    Args:
        env: any environment with 1-D floating-point ``Box`` observation and action spaces.
        demos: the demonstrations: a path to an ``.npz`` episode set, an :class:`EpisodeSet`, or a
            dict of its arrays (``obs``, ``act``, ``rew``, ``ep_len``, ``crashed``, ``meta``).
            Crashed episodes are the unsafe group, the others the safe group.
        strategy: ``"SAFE/UNSAFE"``, each an aggregation (``Min``, ``Max``, ``Mean``) followed by
            a window (``Both``, ``Equal``, ``TrajW5``, ``DemoW5``, ``BothW5``, ``TrajW10``,
            ``DemoW10``, ``BothW10``); see :func:`defender_rl.strategies`. Or ``"auto"``: chosen
            from ``demos`` (with ``mode`` and ``num_demos``) by the selection of
            ``defender train --strategy auto`` (leave-one-out over the demonstrations, without
            the ``Equal`` window; :func:`defender_rl.select`), before the first step, under plain
            and under z-scored DTW unless ``scaling`` is given; the choice and its scores are
            :attr:`strategy` and :attr:`strategy_selection` (with the ``scaling`` chosen). It
            takes seconds to a minute (about 26 s per scaling for Hopper-v5's shipped 50 + 50,
            on two cores) and each
            wrapper chooses again: for several environments, choose once with
            :func:`defender_rl.select` and pass the strategy.
        mode: ``"state"`` or ``"state-action"``.
        num_demos: use the first N demonstrations of each group (all by default).
        r_task: the reward of a filtered step; default: the lowest per-step reward of the
            demonstrations used.
        dynamics: dynamics-model settings (keys of ``DynamicsConfig``: ``hidden``,
            ``learning_rate``, ``batch_size``, ``buffer_size``, ``learning_starts``,
            ``train_freq``, ``gradient_steps``, ``error_ema_alpha``, ``background``). With
            ``background=True`` the model trains on a Rust thread of its own, with the same
            result, while Python (e.g. PyTorch) works.
        seed: seeds the dynamics model's weights and sampling (``ChaCha8Rng::seed_from_u64``);
            random when None.
        scaling: ``"none"`` (SPEC section 2's plain DTW on the raw observations) or
            ``"zscore"``: every feature is standardised with the demonstrations' mean and
            standard deviation before DTW, as ``[defender.cost] scaling = "zscore"`` in a run's
            configuration. ``None`` (the default): plain DTW for a given strategy, and for
            ``strategy="auto"`` whichever of the two its selection ranks higher (z-scored on the
            shipped Hopper-v5, Walker2d-v5 and InvertedDoublePendulum-v5 sets, where it
            separates safe from unsafe demonstrations far better: docs/decisions.md).

        filter: the filter's precision options, as ``[defender.filter]`` of a run's configuration
            (over ``profile``'s): ``{"margin": m}`` filters only when
            ``Unsafe <= (1 - m) * Safe``; ``{"budget": {"share": s, "episodes": n}}`` adapts the
            margin after every episode towards a share ``s`` of filtered episodes (time constant
            ``n`` episodes, default 100); ``{"own_episodes": {"keep": k}}`` lets the agent's own
            episodes join the demonstrations (its crashes the unsafe group, episodes that reach
            the horizon the safe one; at most ``k`` per group, the oldest replaced). The margin
            and own-episode counts in use are in :attr:`filter_state`. Keys given here win over
            ``profile``'s.
        profile: ``"keeps-learning"`` (the default): the filter of ``defender train``'s default
            profile (``{"margin": 0.02, "own_episodes": {"keep": 50}}``; docs/SPEC.md, section
            11); ``"spec"``: SPEC's filter as the paper's text has it, unless ``filter`` says
            otherwise. That
            profile's other half is the learner's, which a wrapper cannot change: the runs that
            held the bar also put every demonstration transition into SAC's replay buffer and
            added a behaviour-cloning term (docs/results-keeps-learning.md); the filter alone
            reached 59% of bare SAC's late return on Hopper-v5.
        check_finite: a NaN or infinity in a reward or observation of the wrapped environment, or
            in an action given to :meth:`step`, raises :class:`DefenderError` naming the step, the
            field and the element (as Stable-Baselines3's ``VecCheckNan`` does, but on by
            default: such a value would otherwise reach the dynamics model and the agent).
            ``False`` lets them through.
        cost_key: the key of the wrapped environment's step ``info`` that holds the step's safety
            cost (docs/SPEC.md, section 12; safety-gymnasium's Gymnasium-API conversion puts it
            under ``"cost"``, the default). The cost used is returned as ``info["cost"]`` (replacing
            the environment's own ``"cost"`` when ``cost_key`` names another key) and carried by
            the Rust ``DefenderEnv``'s step, as ``defender train`` carries its tasks' costs. A
            filtered step costs 0: its action never reached the environment. A step whose
            ``info`` lacks the default key costs by the crash rule ``defender train`` applies on
            Hopper-v5 and the other crash tasks: 1 when the environment terminated the episode,
            else 0. A key passed explicitly must be in every step's ``info``: a step without it
            raises :class:`DefenderError` naming ``cost_key``, the key and the ``info`` keys there
            are. ``None``: no key, the crash rule on every step. A cost that is not a number
            raises ``TypeError``; a negative or non-finite one raises :class:`DefenderError`,
            naming the key.
        episode_cost_limit: on a task whose safety is a per-step cost (Safety-Gymnasium's, limit
            25), an episode is unsafe once its summed cost passes this limit: the agent's own
            episodes join the unsafe group cut at that step, and the safe group when they reach
            the horizon within it (docs/SPEC.md, section 13). ``None`` (the default): the limit
            the demonstrations were labelled by (their ``meta`` ``episode_cost_limit``, written by
            ``defender demos collect`` on a cost task), else the crash rule. A limit that the
            demonstrations were not labelled by raises :class:`DefenderError` naming
            ``episode_cost_limit``.

    The constructor's arguments pickle (paths, ``EpisodeSet`` and numpy arrays), so
    ``SubprocVecEnv`` and ``gymnasium.vector.AsyncVectorEnv`` can build it in their workers.

    Threads: like any Gymnasium environment, one wrapper runs one episode, so step it from one
    thread. If several threads call it anyway (e.g. a monitoring thread reading
    :attr:`defender_stats`), each call waits for the one in progress to return, with the GIL
    released (so the wrapped environment's own code can finish), and Ctrl-C still interrupts
    the wait. A call from inside the wrapped environment's ``step``/``reset`` (or a callback it
    runs) back into this wrapper cannot wait for itself: it raises ``RuntimeError`` at once,
    naming the method called and the one in progress.
    """

    def __init__(
        self,
        env: gym.Env,
        demos: str | os.PathLike | EpisodeSet | Mapping[str, Any],
        strategy: str = "MeanDemoW5/MeanDemoW10",
        *,
        mode: str = "state",
        num_demos: int | None = None,
        r_task: float | None = None,
        dynamics: Mapping[str, Any] | None = None,
        seed: int | None = None,
        scaling: str | None = None,
        check_finite: bool = True,
        filter: Mapping[str, Any] | None = None,  # noqa: A002 (the [defender.filter] section's name)
        profile: str = "keeps-learning",
        cost_key: str | None = _DEFAULT_COST_KEY,
        episode_cost_limit: float | None = None,
    ):
        if not isinstance(env, gym.Env):
            raise TypeError(f"DefenderWrapper wraps a gymnasium.Env, got {type(env).__name__}")
        cost_key_required = cost_key is not _DEFAULT_COST_KEY
        # Recorded only when given, so that a rebuilt wrapper keeps the default's leniency.
        given = {"cost_key": cost_key} if cost_key_required else {}
        if episode_cost_limit is not None:
            if isinstance(episode_cost_limit, (bool, np.bool_)) or not isinstance(
                episode_cost_limit, (int, float, np.integer, np.floating)
            ):
                raise TypeError(f"episode_cost_limit must be a number or None, got {episode_cost_limit!r}")
            episode_cost_limit = float(episode_cost_limit)
            given["episode_cost_limit"] = episode_cost_limit
        gym.utils.RecordConstructorArgs.__init__(
            self, demos=demos, strategy=strategy, mode=mode, num_demos=num_demos, r_task=r_task,
            dynamics=dynamics, seed=seed, scaling=scaling, check_finite=check_finite, filter=filter,
            profile=profile, **given,
        )  # so that env.spec (and gymnasium.make(env.spec)) can rebuild the wrapper
        gym.Wrapper.__init__(self, env)
        _warn_statistics_inside(env)
        obs_space = _check_box(env.observation_space, "observation space")
        act_space = _check_box(env.action_space, "action space")
        if not np.all(np.isfinite(act_space.low)) or not np.all(np.isfinite(act_space.high)):
            raise TypeError(f"DefenderWrapper needs a bounded action space, got {act_space}")
        if not isinstance(strategy, str):
            raise TypeError(f"strategy must be a string such as 'MeanDemoW5/MeanDemoW10', got {strategy!r}")
        if not isinstance(mode, str):
            raise TypeError(f"mode must be 'state' or 'state-action', got {mode!r}")
        if scaling is not None and not isinstance(scaling, str):
            raise TypeError(f"scaling must be 'none', 'zscore' or None, got {scaling!r}")
        num_demos = whole("num_demos", num_demos, 1, I64_MAX, optional=True)
        if r_task is not None:
            if isinstance(r_task, (bool, np.bool_)):
                raise TypeError(f"r_task must be a number or None, got {r_task!r} (a bool)")
            try:
                r_task = float(r_task)
            except (TypeError, ValueError, OverflowError):
                raise TypeError(f"r_task must be a number or None, got {r_task!r}") from None
            if not math.isfinite(r_task):
                raise DefenderError(f"r_task must be a finite number, got {r_task}")
        seed = whole("seed", seed, 0, U64_MAX, optional=True)
        if not isinstance(check_finite, (bool, np.bool_)):
            raise TypeError(f"check_finite must be True or False, got {check_finite!r}")
        if cost_key is not None and not isinstance(cost_key, str):
            raise TypeError(f"cost_key must be a string (a key of the step's info) or None, got {cost_key!r}")
        dynamics_json = None
        if dynamics is not None:
            if not isinstance(dynamics, Mapping):
                raise TypeError(f"dynamics must be a dict of DynamicsConfig fields, got {type(dynamics).__name__}")
            dynamics_json = json.dumps({k: _dynamics_value(k, v) for k, v in dynamics.items()})
        if not isinstance(profile, str):
            raise TypeError(f"profile must be 'spec' or 'keeps-learning', got {profile!r}")
        if filter is not None and not isinstance(filter, Mapping):
            raise TypeError(f"filter must be a dict of [defender.filter] settings, got {type(filter).__name__}")
        # The profile's settings, then what `filter` gives over them (as `defender train --profile`
        # fills around the configuration's keys).
        merged = {**json.loads(profile_filter(profile)), **dict(filter or {})}
        filter_json = json.dumps(_filter_values(merged)) if merged else None
        self._profile = profile
        if isinstance(demos, (str, os.PathLike)):
            demos = os.fspath(demos)
        env_id = env.spec.id if env.spec is not None else None
        # The selection takes tens of seconds: say so, as `defender train --strategy auto` does.
        announce = strategy == "auto" and _progress_on()
        if announce:
            _say("DefenderWrapper: strategy='auto': ranking the strategies on the demonstrations by "
                 "leave-one-out, as `defender select` does (about half a minute per scaling for 50 + 50 "
                 "Hopper-v5 demonstrations on two cores; DEFENDER_PROGRESS_INTERVAL=off: silent) ...")
        started = time.monotonic()
        self._core = Core(
            env,
            env_id,
            obs_space.low,
            obs_space.high,
            obs_space.dtype,
            act_space.low,
            act_space.high,
            demos,
            strategy,
            mode,
            num_demos,
            r_task,
            dynamics_json,
            seed,
            scaling,
            bool(check_finite),
            filter_json,
            None if cost_key is None else str(cost_key),
            cost_key_required,
            episode_cost_limit,
        )
        if announce:
            _say(f"DefenderWrapper: strategy='auto' chose {self.strategy} in {time.monotonic() - started:.0f} s")
        self._check_horizon(demos, env, num_demos)
        # DynamicsConfig's default learning_starts is 1 (crates/defender/src/dynamics.rs).
        self._dynamics_learning_starts = int(dict(dynamics or {}).get("learning_starts", 1))

    @staticmethod
    def _check_horizon(demos, env: gym.Env, num_demos) -> None:
        """Warns when safe demonstrations end before the task's horizon (they were accepted)."""
        if isinstance(demos, str):
            demos = EpisodeSet.load(demos)
        elif isinstance(demos, Mapping):
            demos = EpisodeSet.from_arrays(**demos)
        if isinstance(demos, EpisodeSet):
            warn_short_safe(demos, env_horizon(env), "DefenderWrapper", num_demos=num_demos, stacklevel=4)
            warn_time_limit(env, demos, "DefenderWrapper", num_demos=num_demos, stacklevel=4)

    # -- Gymnasium API ------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        obs, info = self._core.reset(seed, options)
        for key, value in RESET_INFO.items():
            info.setdefault(key, value)
        return obs, info

    def step(self, action) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        return self._core.step(action)

    def close(self):
        self._core.close()
        super().close()

    def __reduce_ex__(self, protocol):
        # A built wrapper holds the Rust core (the dynamics model, its thread, the filter), which
        # does not pickle; what pickles is the recipe to build one, in each worker.
        raise pickle.PicklingError(
            "a built DefenderWrapper does not pickle (it holds its Rust core: the dynamics model and "
            "the filter). Pass a function that builds it instead, e.g. "
            "gymnasium.vector.AsyncVectorEnv([lambda: DefenderWrapper(gym.make(ENV_ID), demos)] * N), "
            "SB3's SubprocVecEnv([lambda: ...]), or gymnasium.make_vec(ENV_ID, N, wrappers=[lambda e: "
            "DefenderWrapper(e, demos)]); its constructor's arguments pickle. To keep its learned state, "
            "use save_state/load_state."
        )

    # -- DEFENDER -----------------------------------------------------------------------------

    @property
    def defender_stats(self) -> dict[str, int]:
        """Counters since construction: ``steps``, ``filtered_steps``, ``real_steps``,
        ``episodes``, ``filtered_episodes``, ``crashed_episodes``, ``truncated_episodes``."""
        return self._core.stats()

    @property
    def profile(self) -> str:
        """The profile the filter's settings started from (``profile=``)."""
        return self._profile

    @property
    def filter_state(self) -> dict[str, float]:
        """The filter's precision options as they stand (``filter=``; they move between
        episodes): ``margin`` in use, ``own_safe`` and ``own_unsafe`` (own episodes kept)."""
        return self._core.filter_state()

    @property
    def last_decision(self) -> tuple[bool, float, float] | None:
        """The last step's ``(filtered, safe_cost, unsafe_cost)``."""
        return self._core.last_decision()

    @property
    def last_outcome(self) -> str | None:
        """How the last finished episode ended: ``crashed``, ``filtered`` or ``truncated``."""
        return self._core.last_outcome()

    @property
    def r_task(self) -> float:
        """The reward of a filtered step, as used."""
        return self._core.r_task()

    @property
    def strategy(self) -> str:
        """The strategy in use (with ``strategy="auto"``, the one chosen)."""
        return self._core.config()[0]

    @property
    def strategy_selection(self) -> dict[str, Any] | None:
        """With ``strategy="auto"``: how the strategy was chosen, as ``defender train`` records it
        in ``summary.json`` (``strategy``, ``candidates``, ``false_alarm_rate``,
        ``crash_prevention_rate``, ``safe_allowed``, ``unsafe_allowed``, ``mean_lead``, ``score``,
        ``safe_demos``, ``unsafe_demos``, ``min_lead``, ``max_false_alarm``, ``equal``,
        ``seconds``); None for a given strategy."""
        return self._core.selection()

    @property
    def mode(self) -> str:
        return self._core.config()[1]

    @property
    def dynamics_learning_starts(self) -> int:
        """Real transitions the dynamics model collects before it first trains."""
        return self._dynamics_learning_starts

    @property
    def dynamics_info(self) -> dict[str, float]:
        """The dynamics model's counters and its prediction error on fresh transitions."""
        return self._core.dynamics_info()

    def predict(self, obs, action) -> np.ndarray:
        """The dynamics model's prediction of the next observation (float64; it does not learn)."""
        return self._core.predict(obs, action)

    def save_state(self, path: str | os.PathLike) -> None:
        """Writes the dynamics model (weights, optimiser, transitions, RNG) and the counters into
        the folder ``path`` (made if missing; it must be empty). Call it between episodes, e.g.
        beside an agent's checkpoint; :meth:`load_state` restores them."""
        self._core.save_state(os.fspath(path))

    def load_state(self, path: str | os.PathLike) -> None:
        """Restores what :meth:`save_state` wrote; call :meth:`reset` next."""
        self._core.load_state(os.fspath(path))
