"""A DEFENDER-wrapped Safety-Gymnasium task as an OmniSafe 0.5.0 environment (a CMDP).

Written against omnisafe 0.5.0 as PyPI ships it (tools/peers/omnisafe-venv.sh), whose code is later than
the repository's v0.5.0 tag: it has `env_cfgs`, `max_episode_steps`, `spec_log` and SACLag's
warm-up actions drawn by torch, which the tag has not.

Importing this module registers, with OmniSafe's own `env_register`, the environment ids
`Defender-<task>` for the Safety-Gymnasium tasks below; then any OmniSafe agent trains on them
through OmniSafe's API:

    import omnisafe
    import omnisafe_defender_env  # tools/peers/ on sys.path

    env_id = omnisafe_defender_env.configure("SafetyHopperVelocity-v1", strategy="MinBothW5/MinBothW10")
    omnisafe.Agent("SACLag", env_id, custom_cfgs={"lagrange_cfgs": {"cost_limit": 25.0}}).learn()

The training environment is `DefenderWrapper(SafetyGymnasium2Gymnasium(safety_gymnasium.make(task)),
demos, episode_cost_limit=25, ...)`: every step goes through DEFENDER's filter, and OmniSafe's agent
sees the wrapper's step as it is (docs/SPEC.md sections 5, 12 and 13):

  * an executed step: the task's observation, reward and `info["cost"]` (OmniSafe's cost), its
    `terminated` and `truncated` (the task's own time limit, 1,000 steps, sits inside the wrapper:
    DEFENDER must see an episode reach the horizon to call it safe);
  * a filtered step (the action never reached the task): the dynamics model's predicted
    observation (OmniSafe's AutoReset puts it in `info["final_observation"]`), reward `R_task` (the
    lowest per-step reward of the demonstrations), cost 0, `terminated=True` (so the transition is
    terminal in OmniSafe's buffer and the episode ends there). OmniSafe counts it as a step of its
    budget and of the episode's `EpLen`; it adds nothing to `EpCost`.

Every step's `info` carries the wrapper's keys (`defender_filtered`, `defender_safe_cost`,
`defender_unsafe_cost`, and on an episode's last step `defender_outcome`).

The evaluation environment OmniSafe builds beside it (`OnlineAdapter._eval_env`, the same id) is the
bare task, unfiltered: OmniSafe's `TestEpRet`/`TestEpCost` measure the policy alone, as the paper's
evaluation (docs/SPEC.md section 6) and the unfiltered columns of our `eval.csv` do. OmniSafe 0.5.0
builds both through the same `make(env_id, ...)`, so this module wraps `OnlineAdapter.__init__` to
mark the one it keeps as `_eval_env` (nothing else of OmniSafe changes). The wrapper is built at the environment's
first reset, so the evaluation environment never builds one (nor runs `strategy="auto"`'s selection).

Seeds: OmniSafe calls `set_seed(cfgs.seed)` on the training environment; its first reset takes
that seed, the next ones none (the task's generator goes on), and the seed also seeds DEFENDER's
dynamics model unless `configure` gave a `seed` of its own (OmniSafe seeds torch, whose generator
draws SACLag's random warm-up actions, and leaves the evaluation environment unseeded, as with its
own Safety-Gymnasium environments).

Configuration: `configure(task, demos, **wrapper)` for any agent; or OmniSafe's `env_cfgs`
(`custom_cfgs={"env_cfgs": {"strategy": ...}}`), which OmniSafe passes to the constructor of both
environments: DefenderWrapper's keyword arguments (and `demos`) among them override `configure`'s,
the others go to `safety_gymnasium.make`. OmniSafe 0.5.0 accepts `env_cfgs` only for algorithms
whose configuration file has that key (PPOLag's has, SACLag's has not).

OmniSafe's logger: each finished training episode stores `Defender/Filtered`, `Defender/Crashed`
and `Defender/Truncated` (1 for its outcome, else 0) through the CMDP's `spec_log`, so
progress.csv's columns of those names are the shares of the epoch's finished episodes that DEFENDER
ended, that the task terminated and that reached the horizon (nan in an epoch where none ended).

OmniSafe closes the training environment when `learn()` ends; `summary()` still answers then (the
wrapper's counters, strategy, `R_task`, ... as they stood at the close).

Not supported: several environments in one process (`train_cfgs.vector_env_nums` > 1): each would
need a filter of its own. OmniSafe's `Evaluator` (`Agent.evaluate`/`render` after training) builds
the environment outside an adapter, so it gets a fresh filter; evaluate the bare task instead.

docs/peers.md, "OmniSafe's agents on a DEFENDER-wrapped task"; tools/peers/omnisafe_defender.py is the
command line; python/tests_omnisafe runs both (`make test-omnisafe`).
"""

from __future__ import annotations

import functools
import os
from typing import Any, Callable, ClassVar

import numpy as np
import torch

from omnisafe.envs.core import CMDP, Wrapper, env_register
from omnisafe_saclag import VELOCITY_TASKS  # tools/peers/ on sys.path, as this module itself

PREFIX = "Defender-"

NAVIGATION_TASKS = ("SafetyPointGoal1-v0", "SafetyCarGoal1-v0")
#: Safety-Gymnasium's velocity tasks (data/demos/ ships sets for Hopper, Walker2d and HalfCheetah;
#: the others need `demos=`) and the two navigation tasks (`demos=` needed).
TASKS = VELOCITY_TASKS + NAVIGATION_TASKS

#: The per-episode cost limit of the field's benchmarks (Safety-Gymnasium's, OmniSafe's): 25.
COST_LIMIT = 25.0

_SOURCE_TREE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: DefenderWrapper's keyword arguments per task id, set by `configure`.
_options: dict[str, dict[str, Any]] = {}

#: Every environment of ours built in this process, in order (OmniSafe keeps them private).
environments: list[DefenderSafetyGymnasiumEnv] = []

#: Called as `f(env, outcome, length, cost, steps)` when an episode of a training environment
#: ends: outcome crashed|filtered|truncated, its steps (a filtered one included), its cost (the
#: executed steps'), the wrapper's steps so far (OmniSafe's training steps).
episode_listeners: list[Callable[..., None]] = []


def env_id(task: str) -> str:
    """OmniSafe's id of the DEFENDER-wrapped `task`: `Defender-<task>`."""
    return PREFIX + task


def task_of(env_id_: str) -> str:
    """The Safety-Gymnasium task of an id of ours (`Defender-<task>`)."""
    if not env_id_.startswith(PREFIX) or env_id_[len(PREFIX):] not in TASKS:
        raise ValueError(f"{env_id_!r} is not one of {[env_id(t) for t in TASKS]}")
    return env_id_[len(PREFIX):]


def shipped_demos(task: str) -> str | None:
    """The demonstrations of `task` shipped with the project: `$DEFENDER_DATA/demos/<task>.npz` when
    DEFENDER_DATA is set (as the `defender` command reads it), else the source tree's
    `data/demos/<task>.npz`; None when there is no such file."""
    root = os.environ.get("DEFENDER_DATA") or os.path.join(_SOURCE_TREE, "data")
    path = os.path.join(root, "demos", f"{task}.npz")
    return path if os.path.isfile(path) else None


def configure(task: str, demos: str | os.PathLike | None = None, **wrapper: Any) -> str:
    """Sets how `Defender-<task>` wraps `task` (from its next construction on) and returns that id.

    `demos`: the demonstration set (`.npz`); default: `shipped_demos(task)`, which exists for the
    velocity tasks of data/demos/ only. `wrapper`: keyword arguments of `DefenderWrapper`
    (`strategy`, `scaling`, `profile`, `filter`, `dynamics`, `seed`, `episode_cost_limit`, ...);
    `episode_cost_limit` defaults to 25 (the set must be labelled by that limit, docs/SPEC.md
    section 13; the wrapper refuses another). Unconfigured tasks use all these defaults.
    """
    if task not in TASKS:
        raise ValueError(f"task {task!r}: one of {list(TASKS)}")
    if demos is None:
        demos = shipped_demos(task)
        if demos is None:
            raise FileNotFoundError(
                f"no demonstrations shipped for {task} (data/demos/{task}.npz, or DEFENDER_DATA/demos/): "
                "give demos=PATH (tools/peers/omnisafe_defender.py: --demos PATH); DemoRecorder / collect_demos "
                "with episode_cost_limit=25 record a set (README, Python)"
            )
    demos = os.fspath(demos)
    if not os.path.isfile(demos):
        raise FileNotFoundError(f"demos {demos!r}: no such file")
    if "env" in wrapper:
        raise TypeError("configure(task, demos, **wrapper): the wrapper's env is the task itself")
    _options[task] = {"demos": demos, "episode_cost_limit": COST_LIMIT, **wrapper}
    return env_id(task)


def _wrapper_options(task: str) -> dict[str, Any]:
    if task not in _options:
        configure(task)
    return dict(_options[task])


def _make_task(task: str, **kwargs: Any):
    """Safety-Gymnasium's task in Gymnasium's API (its cost in `info["cost"]`), with the task's own
    time limit (1,000 steps) inside."""
    import safety_gymnasium
    from safety_gymnasium.wrappers import SafetyGymnasium2Gymnasium

    return SafetyGymnasium2Gymnasium(safety_gymnasium.make(task, **kwargs))


#: DefenderWrapper's keyword arguments (and `demos`): in OmniSafe's `env_cfgs`, these configure
#: the wrapper; the other keys go to `safety_gymnasium.make`.
WRAPPER_KEYS = frozenset((
    "demos", "strategy", "mode", "num_demos", "r_task", "dynamics", "seed", "scaling", "check_finite",
    "filter", "profile", "cost_key", "episode_cost_limit",
))

#: The keys this environment stores in OmniSafe's logger at each finished training episode.
LOG_KEYS = {"filtered": "Defender/Filtered", "crashed": "Defender/Crashed", "truncated": "Defender/Truncated"}


@env_register
class DefenderSafetyGymnasiumEnv(CMDP):
    """A Safety-Gymnasium task under `defender_rl.DefenderWrapper`, as an OmniSafe CMDP (one
    environment). The evaluation environment OmniSafe builds beside the training one steps the
    bare task (module docstring)."""

    _support_envs: ClassVar[list[str]] = [env_id(t) for t in TASKS]
    # OmniSafe's AutoReset resets after a terminated or truncated step and puts the last
    # observation into info["final_observation"]; the time limit is the task's own, inside the
    # wrapper (DEFENDER must see an episode reach the horizon), so OmniSafe's TimeLimit is not used.
    need_auto_reset_wrapper: bool = True
    need_time_limit_wrapper: bool = False

    def __init__(self, env_id: str, num_envs: int = 1, device: torch.device | str = "cpu", **kwargs: Any) -> None:  # noqa: A002
        super().__init__(env_id)
        if num_envs != 1:
            raise ValueError(
                f"{env_id}: num_envs={num_envs}; a DEFENDER-wrapped task runs one environment "
                "(train_cfgs.vector_env_nums = 1): each environment would need a filter of its own"
            )
        self.task = task_of(env_id)
        self._num_envs = 1
        self._device = torch.device(device)
        given = {k: kwargs.pop(k) for k in list(kwargs) if k in WRAPPER_KEYS}
        if "demos" in given:
            given["demos"] = os.fspath(given["demos"])
        if self.task in _options or "demos" not in given:
            self._options = {**_wrapper_options(self.task), **given}
        else:  # env_cfgs name the demonstrations: configure's defaults are not needed
            self._options = {"episode_cost_limit": COST_LIMIT, **given}
        self._task_env = _make_task(self.task, **kwargs)
        self._action_space = self._task_env.action_space
        self._observation_space = self._task_env.observation_space
        self._metadata = self._task_env.metadata
        self._defender = None  # the DefenderWrapper, built at the first reset of a training env
        self._summary: dict[str, Any] | None = None  # summary() as it stood at close()
        self._evaluation = False
        self._seed: int | None = None  # set_seed's, for the first reset
        self._episode: list[float] = [0, 0.0]  # steps and cost of the episode so far
        self._outcome: str | None = None  # of the episode that ended last
        self.env_spec_log = dict.fromkeys(LOG_KEYS.values(), 0.0)  # OmniSafe registers these keys
        environments.append(self)

    # -- what OmniSafe's adapter tells us ---------------------------------------------------------

    def evaluation(self) -> None:
        """Makes this the evaluation environment: the bare task, never filtered."""
        if self._defender is not None:
            raise RuntimeError(f"{self.task}: already stepped with DEFENDER; evaluation() comes before the first reset")
        self._evaluation = True

    @property
    def is_evaluation(self) -> bool:
        return self._evaluation

    @property
    def defender(self):  # noqa: ANN201 (defender_rl.DefenderWrapper or None)
        """The DefenderWrapper of a training environment once it has been reset; else None."""
        return self._defender

    def summary(self) -> dict[str, Any] | None:
        """The wrapper's counters (`defender_stats`), strategy (and `strategy_selection`), mode,
        profile, `R_task`, filter state and dynamics model's counters, and the demonstrations'
        path: now, or as they stood when OmniSafe closed the environment; None before the wrapper
        was built (an evaluation environment never builds one)."""
        if self._summary is not None or self._defender is None:
            return self._summary
        w = self._defender
        return {
            "demos": self._options["demos"],
            "defender_stats": w.defender_stats,
            "strategy": w.strategy,
            "strategy_selection": w.strategy_selection,
            "mode": w.mode,
            "profile": w.profile,
            "r_task": w.r_task,
            "episode_cost_limit": self._options.get("episode_cost_limit"),
            "filter_state": w.filter_state,
            "dynamics_info": w.dynamics_info,
        }

    def spec_log(self, logger) -> None:  # noqa: ANN001 (OmniSafe's Logger)
        """OmniSafe's per-episode hook: the outcome of the training episode that just ended."""
        if self._outcome is not None:
            logger.store({key: float(outcome == self._outcome) for outcome, key in LOG_KEYS.items()})

    def _gym_env(self, seed: int | None = None):  # noqa: ANN202
        """The bare task (evaluation) or the DefenderWrapper around it, built on first use with
        `seed` for its dynamics model unless the configuration gave one."""
        if self._evaluation:
            return self._task_env
        if self._defender is None:
            from defender_rl import DefenderWrapper

            options = self._options
            if options.get("seed") is None and seed is not None:
                options = {**options, "seed": seed}
            self._defender = DefenderWrapper(self._task_env, **options)
        return self._defender

    # -- the CMDP -------------------------------------------------------------------------------

    def step(
        self, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, dict[str, Any]]:
        env = self._gym_env()
        obs, reward, terminated, truncated, info = env.step(action.detach().cpu().numpy())
        cost = float(info["cost"])
        self._episode[0] += 1
        self._episode[1] += cost
        if (terminated or truncated) and self._defender is not None:
            self._outcome = str(info["defender_outcome"])
            steps = int(self._defender.defender_stats["steps"])
            for listener in episode_listeners:
                listener(self, self._outcome, int(self._episode[0]), self._episode[1], steps)
        obs, reward, cost, terminated, truncated = (
            torch.as_tensor(np.asarray(x), dtype=torch.float32, device=self._device)
            for x in (obs, reward, cost, terminated, truncated)
        )
        return obs, reward, cost, terminated, truncated, info

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[torch.Tensor, dict[str, Any]]:
        if seed is None:
            seed = self._seed  # set_seed's, at the first reset after it
        self._seed = None
        env = self._gym_env(seed)
        obs, info = env.reset(seed=seed, options=options)
        self._episode = [0, 0.0]
        return torch.as_tensor(obs, dtype=torch.float32, device=self._device), info

    def set_seed(self, seed: int) -> None:
        """Seeds the next reset, DEFENDER's dynamics model and the action space's sampling."""
        self._seed = int(seed)
        self._action_space.seed(int(seed))

    @property
    def max_episode_steps(self) -> int | None:
        """The task's time limit (1,000 steps), applied inside the wrapper."""
        spec = self._task_env.spec
        return spec.max_episode_steps if spec is not None else None

    def sample_action(self) -> torch.Tensor:
        return torch.as_tensor(self._action_space.sample(), dtype=torch.float32, device=self._device)

    def render(self) -> Any:
        return self._task_env.render()

    def close(self) -> None:
        if self._defender is not None and self._summary is None:
            self._summary = self.summary()
        (self._defender or self._task_env).close()


def _evaluation_env_unfiltered() -> None:
    """Wraps OmniSafe 0.5.0's `OnlineAdapter.__init__` so that, once it has built its two
    environments, ours among them kept as `_eval_env` steps the bare task (module docstring).
    Idempotent."""
    from omnisafe.adapter.online_adapter import OnlineAdapter

    original = OnlineAdapter.__init__
    if getattr(original, "_defender_marks_evaluation", False):
        return

    @functools.wraps(original)
    def __init__(self, *args: Any, **kwargs: Any) -> None:  # noqa: N807, ANN001
        original(self, *args, **kwargs)
        env = self._eval_env
        while isinstance(env, Wrapper):
            env = env._env  # noqa: SLF001 (OmniSafe's wrappers keep the inner env there)
        if isinstance(env, DefenderSafetyGymnasiumEnv):
            env.evaluation()

    __init__._defender_marks_evaluation = True  # type: ignore[attr-defined]
    OnlineAdapter.__init__ = __init__


_evaluation_env_unfiltered()


def task_cfgs(algo: str, task: str) -> dict[str, Any]:
    """OmniSafe's own settings for `task` in `algo`'s configuration file (e.g. SACLag.yaml's
    `SafetyPointGoal1-v0:` section), which OmniSafe applies by env id and so would not apply to
    `Defender-<task>`: pass them in `custom_cfgs` (under your own) for the same agent. {} when the
    file has none (the velocity tasks)."""
    import omnisafe.utils.config as config
    from omnisafe.algorithms import ALGORITHM2TYPE

    path = os.path.join(os.path.dirname(config.__file__), "..", "configs", ALGORITHM2TYPE[algo], f"{algo}.yaml")
    return dict(config.load_yaml(path).get(task) or {})
