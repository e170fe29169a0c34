"""Checkpoints of OmniSafe 0.5.0's off-policy training between epochs, for an exact resume.

tools/peers/omnisafe_saclag.py trains SACLag for hours; a session that ends kills the process. This
module lets it stop at any moment and continue from the last checkpoint with the same episodes,
evaluations and progress.csv rows as a run left alone (docs/peers.md, "Resuming a run").

What OmniSafe carries from one epoch to the next is all reachable from the algorithm object
(SACLag, a DDPG subclass): the actor-critic and its target networks, their optimisers and the
learning-rate scheduler, the replay buffer, the Lagrange multiplier and its optimiser, the update
counter, the logger's windows (SACLag's multiplier update reads `Metrics/EpCost`'s last 50
episodes), and the adapter: the current observation, the running episode sums, and the training
and evaluation environments under all of OmniSafe's and safety-gymnasium's wrappers (time limit
counters, the cost normaliser, the MuJoCo MjData mid-episode, each environment's np_random). So a
checkpoint pickles that object whole, and the process-wide generators (python `random`, numpy's
global one, torch's CPU one) beside it. Three kinds of object are pickled by a rule of ours
(`_Pickler.reducer_override`):

  * gymnasium's EzPickle environments (the MuJoCo tasks): EzPickle pickles the constructor's
    arguments and builds a new environment on load, losing the simulation's state; their
    attributes are pickled instead. MuJoCo 2.3.3's MjModel and MjData pickle themselves whole
    (checked: a copy steps on bit-identically, `qacc_warmstart` included). One catch: pickling an
    MjData that mj_forward never ran on crashes the process (a segmentation fault in MuJoCo 2.3.3,
    even after mj_resetData). An environment's reset runs it, and by a checkpoint every
    environment has been reset: the training one when OmniSafe's adapter is built, the
    evaluation one by tools/peers/omnisafe_saclag.py's seeding and each epoch's evaluation.
  * OmniSafe's Logger: its open files (progress.csv, TensorBoard's writer, the console) are left
    out and reopened on load by `reattach_logger`, after the files are cut back to their length at
    the checkpoint.
  * the replay buffer: OmniSafe allocates all of it at once (1,000,000 rows); only the rows
    written so far are saved (the rest are zeros, never sampled) and the rest is zeros again on
    load: a checkpoint of Hopper at 300k steps is 37 MB (0.1 s to write) where the whole buffer
    alone would be 112 MB (Walker2d: 55 MB, 172 MB).

The epoch loop is `learn`, DDPG.learn's own (which SACLag inherits), started at a given epoch.
"""

from __future__ import annotations

import atexit
import copyreg
import csv
import os
import pickle
import random
import time
from typing import Any, Callable

import numpy as np
import torch
from gymnasium.utils.ezpickle import EzPickle
from omnisafe.common.buffer.offpolicy_buffer import OffPolicyBuffer
from omnisafe.common.logger import Logger

FORMAT = 1  # of the checkpoint file; a change of what it holds changes this
STATE = "state.pkl"


class _Pickler(pickle.Pickler):
    def reducer_override(self, obj: Any) -> Any:  # noqa: ANN401 (pickle's protocol)
        if isinstance(obj, EzPickle):
            return copyreg.__newobj__, (type(obj),), dict(vars(obj)), None, None, _set_attributes
        if isinstance(obj, Logger):
            state = {k: v for k, v in vars(obj).items() if k not in _LOGGER_HANDLES}
            return copyreg.__newobj__, (type(obj),), state, None, None, _set_attributes
        if isinstance(obj, OffPolicyBuffer):
            state = dict(vars(obj))
            # clone: a slice pickles its whole storage.
            state["data"] = {k: v[: obj._size].clone() for k, v in obj.data.items()}
            return copyreg.__newobj__, (type(obj),), state, None, None, _set_buffer
        return NotImplemented


# The Logger's members bound to this process: reopened by reattach_logger.
_LOGGER_HANDLES = ("_output_file", "_csv_writer", "_console", "_tensorboard_writer")


def _set_attributes(obj: Any, state: dict) -> None:  # noqa: ANN401
    vars(obj).update(state)


def _set_buffer(buffer: Any, state: dict) -> None:  # noqa: ANN401
    written = state.pop("data")
    vars(buffer).update(state)
    buffer.data = {}
    for key, rows in written.items():
        full = torch.zeros((buffer._max_size, *rows.shape[1:]), dtype=rows.dtype, device=rows.device)
        full[: rows.shape[0]] = rows
        buffer.data[key] = full


def rng_state() -> dict:
    return {"python": random.getstate(), "numpy": np.random.get_state(), "torch": torch.get_rng_state()}


def set_rng_state(state: dict) -> None:
    random.setstate(state["python"])
    np.random.set_state(state["numpy"])
    torch.set_rng_state(state["torch"])


def save(directory: str, meta: dict, state: dict) -> int:
    """Writes `meta` (small: read alone by `read_meta`) and `state` into directory/state.pkl
    atomically (a temporary file, fsync, rename, fsync of the directory): a kill at any moment
    leaves the previous checkpoint or this one. Returns the file's size in bytes."""
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, STATE)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        pickle.dump({"format": FORMAT, **meta}, f, protocol=pickle.HIGHEST_PROTOCOL)
        _Pickler(f, protocol=pickle.HIGHEST_PROTOCOL).dump(state)
        f.flush()
        os.fsync(f.fileno())
        size = f.tell()
    os.replace(tmp, path)
    fsync_directory(directory)
    return size


def read_meta(directory: str) -> dict | None:
    """The checkpoint's meta, or None when there is none (a `.tmp` left by a kill is not one)."""
    path = os.path.join(directory, STATE)
    if not os.path.exists(path):
        return None
    with open(path, "rb") as f:
        meta = pickle.load(f)
    if meta.get("format") != FORMAT:
        raise ValueError(f"{path}: checkpoint format {meta.get('format')}, this tool reads {FORMAT}")
    return meta


def load(directory: str) -> tuple[dict, dict]:
    with open(os.path.join(directory, STATE), "rb") as f:
        meta = pickle.load(f)
        return meta, pickle.load(f)


def fsync_directory(directory: str) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def file_sizes(root: str, paths: list[str]) -> dict[str, int]:
    """Each file's size (paths relative to root), after an fsync: the checkpoint records how far
    each file it appends to had got, so that a resume cuts off what a killed run wrote after."""
    sizes = {}
    for rel in paths:
        full = os.path.join(root, rel)
        fd = os.open(full, os.O_RDONLY)
        try:
            os.fsync(fd)
            sizes[rel] = os.fstat(fd).st_size
        finally:
            os.close(fd)
    return sizes


def cut_back(root: str, sizes: dict[str, int]) -> None:
    """Truncates each file to its size at the checkpoint (ValueError if one is missing or
    shorter: the files are not the checkpoint's)."""
    for rel, size in sizes.items():
        full = os.path.join(root, rel)
        have = os.path.getsize(full) if os.path.exists(full) else -1
        if have < size:
            raise ValueError(f"{full}: {'missing' if have < 0 else f'{have} bytes'}, the checkpoint recorded {size}")
        os.truncate(full, size)


def logger_files(logger: Any, root: str) -> list[str]:  # noqa: ANN401 (OmniSafe's Logger)
    """The files OmniSafe's logger appends to, relative to root: progress.csv and its TensorBoard
    event files (each process writes a new one; a resume truncates the old ones)."""
    log_dir = os.path.relpath(logger._log_dir, root)
    files = [os.path.join(log_dir, "progress.csv")]
    tb = os.path.join(root, log_dir, "tb")
    if logger._use_tensorboard and os.path.isdir(tb):
        files += sorted(os.path.join(log_dir, "tb", n) for n in os.listdir(tb) if n.startswith("events.out.tfevents."))
    return files


def reattach_logger(logger: Any, root: str, log_dir: str, recorded: dict[str, int]) -> None:  # noqa: ANN401
    """Reopens what `_Pickler` left out of the logger, in root/log_dir: progress.csv for appending
    (cut back already), a new TensorBoard writer (a new event file beside the old ones; event files
    no checkpoint recorded, from a process killed before its first, are removed)."""
    from rich.console import Console

    assert isinstance(logger, Logger)
    logger._log_dir = os.path.join(root, log_dir)
    logger._console = Console()
    logger._output_file = open(os.path.join(logger._log_dir, "progress.csv"), "a", encoding="utf-8")  # noqa: SIM115
    atexit.register(logger._output_file.close)  # as Logger.__init__ does
    logger._csv_writer = csv.writer(logger._output_file)
    if logger._use_tensorboard:
        from torch.utils.tensorboard.writer import SummaryWriter

        tb = os.path.join(logger._log_dir, "tb")
        for name in os.listdir(tb) if os.path.isdir(tb) else []:
            if name.startswith("events.out.tfevents.") and os.path.join(log_dir, "tb", name) not in recorded:
                os.remove(os.path.join(tb, name))
        logger._tensorboard_writer = SummaryWriter(log_dir=tb)


def learn(
    algo: Any, first_epoch: int, elapsed: float, after_epoch: Callable[[int, float], None]  # noqa: ANN401
) -> tuple[float, float, float]:
    """OmniSafe 0.5.0's DDPG.learn (algorithms/off_policy/ddpg.py, lines of `learn` from
    `start_time` to its return; SAC and SACLag inherit it) unchanged but for three things: the
    epochs start at `first_epoch`, Time/Total goes on from `elapsed` seconds, and
    `after_epoch(epochs_done, elapsed)` runs after each epoch's dump_tabular and model save (where
    a checkpoint is taken: nothing of the epoch is left in flight)."""
    cfgs = algo._cfgs
    algo._logger.log("INFO: Start training")
    start_time = time.time() - elapsed
    step = 0
    for epoch in range(first_epoch, algo._epochs):
        algo._epoch = epoch
        rollout_time = 0.0
        update_time = 0.0
        epoch_time = time.time()

        for sample_step in range(epoch * algo._samples_per_epoch, (epoch + 1) * algo._samples_per_epoch):
            step = sample_step * algo._update_cycle * cfgs.train_cfgs.vector_env_nums

            rollout_start = time.time()
            if cfgs.algo_cfgs.use_exploration_noise:
                algo._actor_critic.actor.noise = cfgs.algo_cfgs.exploration_noise
            algo._env.rollout(
                rollout_step=algo._update_cycle,
                agent=algo._actor_critic,
                buffer=algo._buf,
                logger=algo._logger,
                use_rand_action=(step <= cfgs.algo_cfgs.start_learning_steps),
            )
            rollout_time += time.time() - rollout_start

            update_start = time.time()
            if step > cfgs.algo_cfgs.start_learning_steps:
                algo._update()
            else:
                algo._log_when_not_update()
            update_time += time.time() - update_start

        eval_start = time.time()
        algo._env.eval_policy(episode=cfgs.train_cfgs.eval_episodes, agent=algo._actor_critic, logger=algo._logger)
        eval_time = time.time() - eval_start

        algo._logger.store({"Time/Update": update_time})
        algo._logger.store({"Time/Rollout": rollout_time})
        algo._logger.store({"Time/Evaluate": eval_time})

        if step > cfgs.algo_cfgs.start_learning_steps and cfgs.model_cfgs.linear_lr_decay:
            algo._actor_critic.actor_scheduler.step()

        algo._logger.store(
            {
                "TotalEnvSteps": step + 1,
                "Time/FPS": cfgs.algo_cfgs.steps_per_epoch / (time.time() - epoch_time),
                "Time/Total": (time.time() - start_time),
                "Time/Epoch": (time.time() - epoch_time),
                "Train/Epoch": epoch,
                "Train/LR": algo._actor_critic.actor_scheduler.get_last_lr()[0],
            },
        )

        algo._logger.dump_tabular()

        if (epoch + 1) % cfgs.logger_cfgs.save_model_freq == 0:
            algo._logger.torch_save()

        after_epoch(epoch + 1, time.time() - start_time)

    ep_ret = algo._logger.get_stats("Metrics/EpRet")[0]
    ep_cost = algo._logger.get_stats("Metrics/EpCost")[0]
    ep_len = algo._logger.get_stats("Metrics/EpLen")[0]
    algo._logger.close()
    algo._env.close()
    return ep_ret, ep_cost, ep_len
