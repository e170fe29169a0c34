#!/usr/bin/env python3
"""Train OmniSafe 0.5.0's SACLag on a Safety-Gymnasium velocity task, as a peer beside our runs.

OmniSafe is measured against, not used by the project (docs/peers.md). This runs its SACLag with
its own defaults (configs/off-policy/SACLag.yaml: 2,000 steps an epoch, 10,000 random steps, the
multiplier frozen for 100 warm-up epochs, one evaluation episode an epoch) and the field's cost
limit 25, on one seed and budget, one CPU thread. OmniSafe logs by epoch (progress.csv, where each
episode metric, Metrics/EpRet, EpCost, EpLen and their TestEp* twins, is a mean over the last 50
episodes: OmniSafe 0.5.0's DDPG._init_log, which SAC and SACLag inherit, registers them with
window_length=50 written in the code, and does not read the config's logger_cfgs.window_lens: 10);
to put its curve beside ours episode by episode, this also writes every episode as it ends:

  OUT/episodes.csv   episode,total_steps,return,length,cost,wall_seconds: each training episode;
                     episode from 0; total_steps = environment steps taken when it ended (as
                     our metrics.csv's total_steps); return and cost are the episode's sums of the
                     raw reward and cost (OmniSafe's `original_reward`/`original_cost`, before its
                     cost normalisation), length its steps; wall_seconds since training started
                     (the work kept: a resumed run's clock goes on from its checkpoint's).
  OUT/evals.csv      total_steps,return,length,cost,wall_seconds: each deterministic evaluation
                     episode (OmniSafe's: one at each epoch's end).
  OUT/run.json       the arguments and the versions of omnisafe, safety-gymnasium, torch, mujoco;
                     resumed_at_steps: the checkpoints it was resumed from; when training ends,
                     "complete": true, its env_steps and wall_seconds
  OUT/SACLag-{ENV}/seed-SSS-.../  OmniSafe's own logs (progress.csv, config.json, tb/, torch_save/)
  OUT/checkpoint/state.pkl  while training: the last checkpoint (every --checkpoint-every epochs,
                     default 10 = 20,000 steps; ~37 MB for Hopper at 300k steps, most of it the
                     replay buffer); removed when training ends
  OUT/config.toml, metrics.csv, eval.csv, summary.json
                     when training ends: OUT as a run directory that `defender report` reads
                     beside ours (tools/peers/omnisafe_run_dir.py, which also converts by hand)

Resuming: the same command again continues a killed run from its last checkpoint, exactly: the
episodes.csv and evals.csv rows (but wall_seconds), progress.csv (but its Time/* columns) and
TensorBoard's scalars are those of the run left alone (python/tests_omnisafe/test_omnisafe_resume.py
kills one and compares). Rows written after the checkpoint are cut off first; a run killed before
its first checkpoint starts again. Other arguments (but --out and --checkpoint-every) or package
versions than run.json's are refused, naming the differences; a complete run is left alone. What
a checkpoint holds and how: tools/peers/omnisafe_checkpoint.py. One change to what OmniSafe does: its
evaluation environment is seeded with the run's seed (OmniSafe 0.5.0 leaves it to OS entropy, so
that two runs of a seed evaluated from different initial states); training is unchanged.

Run (after `bash tools/peers/omnisafe-venv.sh`), e.g. one seed at the shared budget:
  .deps/omnisafe-venv/bin/python tools/peers/omnisafe_saclag.py --env SafetyHopperVelocity-v1 \\
      --seed 0 --steps 300000 --out results/velocity/omnisafe/hopper-s0
The budget must be a multiple of --steps-per-epoch (OmniSafe's rule). The tasks run on
safety-gymnasium's MuJoCo 2.3.3, not our MuJoCo 3.17: the same task and cost rule, not the same
trajectories.
"""

from __future__ import annotations

import argparse
import csv
import glob
import json
import os
import shutil
import sys
import time
from importlib import metadata

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from omnisafe_run_dir import convert, write_json  # noqa: E402 (tools/peers/ beside this file)

EPISODE_HEADER = ["episode", "total_steps", "return", "length", "cost", "wall_seconds"]
EVAL_HEADER = ["total_steps", "return", "length", "cost", "wall_seconds"]

CHECKPOINT = "checkpoint"  # OUT/checkpoint/state.pkl: tools/peers/omnisafe_checkpoint.py

VELOCITY_TASKS = (
    "SafetyHopperVelocity-v1",
    "SafetyWalker2dVelocity-v1",
    "SafetyHalfCheetahVelocity-v1",
    "SafetyAntVelocity-v1",
    "SafetyHumanoidVelocity-v1",
    "SafetySwimmerVelocity-v1",
)


class EpisodeCsv:
    """Writes rows to a CSV file as they come, flushed at once (a killed run keeps its rows).

    `rows`: a resume's count of the rows already there (the file cut back to them by the
    caller); the file is appended to, its header not written again."""

    def __init__(self, path: str, header: list[str], rows: int | None = None) -> None:
        mode = "w" if rows is None else "a"
        self._file = open(path, mode, newline="", encoding="utf-8")  # noqa: SIM115 (closed in close)
        self._csv = csv.writer(self._file)
        if rows is None:
            self._csv.writerow(header)
            self._file.flush()
        self.rows = rows or 0

    def write(self, row: list) -> None:
        self._csv.writerow(row)
        self._file.flush()
        self.rows += 1

    def close(self) -> None:
        self._file.close()


class Recorder:
    """Every training episode (episodes.csv) and every evaluation episode (evals.csv) as it ends,
    with the environment steps of training so far and the seconds since training started.

    `resume`: a checkpoint's `state()`; the step count, row counts and clock go on from it (the
    clock counts the work kept: time a killed process spent after its last checkpoint is not in
    wall_seconds)."""

    def __init__(self, out: str, resume: dict | None = None) -> None:
        resume = resume or {}
        self.train = EpisodeCsv(os.path.join(out, "episodes.csv"), EPISODE_HEADER, resume.get("episodes"))
        self.evals = EpisodeCsv(os.path.join(out, "evals.csv"), EVAL_HEADER, resume.get("evals"))
        self.steps = resume.get("steps", 0)
        self.start = time.monotonic() - resume.get("wall_seconds", 0.0)

    def wall(self) -> str:
        return f"{time.monotonic() - self.start:.3f}"

    def step(self, num_envs: int) -> None:
        self.steps += num_envs

    def episode(self, ret: float, length: int, cost: float) -> None:
        self.train.write([self.train.rows, self.steps, repr(ret), length, repr(cost), self.wall()])

    def evaluation(self, ret: float, length: int, cost: float) -> None:
        self.evals.write([self.steps, repr(ret), length, repr(cost), self.wall()])

    def state(self) -> dict:
        return {
            "steps": self.steps,
            "wall_seconds": time.monotonic() - self.start,
            "episodes": self.train.rows,
            "evals": self.evals.rows,
        }

    def close(self) -> None:
        self.train.close()
        self.evals.close()


class _EvalLogger:
    """Stands in for OmniSafe's logger during `eval_policy`: hands each evaluation episode's
    `Metrics/TestEp*` values to the recorder, then to the logger unchanged."""

    def __init__(self, logger, recorder: Recorder) -> None:  # noqa: ANN001 (OmniSafe's Logger)
        self._logger, self._recorder = logger, recorder

    def store(self, data: dict, **kwargs) -> None:  # noqa: ANN003
        if "Metrics/TestEpRet" in data:
            self._recorder.evaluation(
                float(data["Metrics/TestEpRet"]), int(data["Metrics/TestEpLen"]), float(data["Metrics/TestEpCost"])
            )
        self._logger.store(data, **kwargs)

    def __getattr__(self, name: str):  # noqa: ANN204
        return getattr(self._logger, name)


def hook_episodes(recorder: Recorder, adapter: type | None = None) -> None:
    """Makes OmniSafe's off-policy adapter (or `adapter`: its on-policy one has the same two
    methods and no evaluation) report each step, finished training episode and evaluation
    episode to `recorder`.

    OmniSafe keeps the episode's sums in `_ep_ret`/`_ep_cost`/`_ep_len` (raw values, before
    normalisation) and passes them to `_log_metrics` when the episode ends, before resetting them;
    `_log_value` runs once per vector step; `eval_policy` stores each evaluation episode's raw
    sums in the logger (whose progress.csv shows only a mean over its last 50 values). All three
    are wrapped, not replaced, so OmniSafe's own logging is unchanged.
    """
    if adapter is None:
        from omnisafe.adapter.offpolicy_adapter import OffPolicyAdapter as adapter

    log_value, log_metrics = adapter._log_value, adapter._log_metrics
    eval_policy = getattr(adapter, "eval_policy", None)

    def _log_value(self, reward, cost, info):  # noqa: ANN001 (OmniSafe's signature)
        log_value(self, reward=reward, cost=cost, info=info)
        recorder.step(self._env.num_envs)

    def _log_metrics(self, logger, idx):  # noqa: ANN001
        recorder.episode(float(self._ep_ret[idx]), int(self._ep_len[idx]), float(self._ep_cost[idx]))
        log_metrics(self, logger, idx)

    def _eval_policy(self, episode, agent, logger):  # noqa: ANN001
        eval_policy(self, episode, agent, _EvalLogger(logger, recorder))

    adapter._log_value = _log_value
    adapter._log_metrics = _log_metrics
    if eval_policy is not None:
        adapter.eval_policy = _eval_policy


def versions() -> dict[str, str]:
    out = {"python": sys.version.split()[0]}
    for name in ("omnisafe", "safety-gymnasium", "torch", "mujoco", "gymnasium", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


# run.json's entries a rerun must repeat to resume (--out and --checkpoint-every may differ).
SAME_RUN = ("algo", "env", "seed", "steps", "cost_limit", "steps_per_epoch", "start_learning_steps", "threads",
            "versions")


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", required=True, choices=VELOCITY_TASKS, help="Safety-Gymnasium task id")
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--steps", type=int, required=True, help="environment steps of training")
    parser.add_argument("--out", required=True, help="output folder (created; the same command again resumes)")
    parser.add_argument("--cost-limit", type=float, default=25.0, help="per-episode cost limit (default 25)")
    parser.add_argument("--steps-per-epoch", type=int, default=2000, help="OmniSafe's default: 2000")
    parser.add_argument(
        "--start-learning-steps", type=int, default=None, help="random steps first (OmniSafe's default: 10000)"
    )
    parser.add_argument("--threads", type=int, default=1, help="torch threads (default 1: one core a run)")
    parser.add_argument(
        "--checkpoint-every", type=int, default=10,
        help="epochs between checkpoints in OUT/checkpoint (default 10: 20,000 steps at 2,000 an epoch; 0: none)",
    )
    args = parser.parse_args()
    if args.steps <= 0 or args.steps % args.steps_per_epoch:
        parser.error(f"--steps {args.steps}: must be a positive multiple of --steps-per-epoch {args.steps_per_epoch}")
    if args.cost_limit <= 0:
        parser.error(f"--cost-limit {args.cost_limit}: must be positive")
    if args.checkpoint_every < 0:
        parser.error(f"--checkpoint-every {args.checkpoint_every}: must be 0 (none) or positive")
    return args


def main() -> int:
    args = parse()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    run = {"algo": "SACLag", **vars(args), "versions": versions(), "complete": False}
    previous = read_previous(out)
    if isinstance(previous, str):
        print(f"omnisafe_saclag: {previous}; choose another --out", file=sys.stderr)
        return 2
    if previous is not None:
        differ = [f"{k}: {previous.get(k)!r} there, {run[k]!r} now" for k in SAME_RUN if previous.get(k) != run[k]]
        if differ:
            print(f"omnisafe_saclag: {out} holds another run (run.json); resuming needs the same arguments and "
                  "versions; choose another --out. Differences:\n  " + "\n  ".join(differ), file=sys.stderr)
            return 2
        if previous.get("complete"):
            shutil.rmtree(os.path.join(out, CHECKPOINT), ignore_errors=True)  # left by a kill at the very end
            print(f"omnisafe_saclag: {out} is complete ({previous.get('env_steps')} steps); nothing to do")
            return 0

    import omnisafe_checkpoint as ck  # after the argument checks: importing torch takes seconds

    checkpoints = os.path.join(out, CHECKPOINT)
    try:
        meta = ck.read_meta(checkpoints) if previous is not None else None
        if meta is not None:
            # Rows written after the checkpoint go: the resumed run writes them again.
            ck.cut_back(out, meta["files"])
    except ValueError as e:
        print(f"omnisafe_saclag: cannot resume: {e}", file=sys.stderr)
        return 2
    if meta is not None:
        algo, recorder = resume(args, out, meta)
        run = {**previous, "checkpoint_every": args.checkpoint_every}
        run["resumed_at_steps"] = [*previous.get("resumed_at_steps", []), meta["env_steps"]]
        write_json(os.path.join(out, "run.json"), run)
        first_epoch, elapsed = meta["epoch"], meta["elapsed"]
    else:
        if previous is not None:
            print(f"omnisafe_saclag: {out} holds an unfinished run without a checkpoint: starting it again")
            for stale in glob.glob(os.path.join(glob.escape(out), f"SACLag-{{{args.env}}}", "seed-*")):
                shutil.rmtree(stale)  # OmniSafe's logs of the attempt: a new one gets a new folder
        write_json(os.path.join(out, "run.json"), run)
        algo, recorder = start(args, out)
        first_epoch, elapsed = 0, 0.0

    def after_epoch(done: int, elapsed: float) -> None:
        if args.checkpoint_every and done % args.checkpoint_every == 0:
            started = time.monotonic()
            files = ["episodes.csv", "evals.csv", *ck.logger_files(algo._logger, out)]
            meta = {
                "epoch": done,
                "env_steps": recorder.steps,
                "elapsed": elapsed,
                "log_dir": os.path.relpath(algo._logger.log_dir, out),
                "recorder": recorder.state(),
                "files": ck.file_sizes(out, files),
            }
            size = ck.save(checkpoints, meta, {"algo": algo, "rng": ck.rng_state()})
            print(f"omnisafe_saclag: checkpoint at epoch {done} ({recorder.steps} steps): "
                  f"{size / 1e6:.1f} MB in {time.monotonic() - started:.2f} s")

    try:
        ep_ret, ep_cost, ep_len = ck.learn(algo, first_epoch, elapsed, after_epoch)
    finally:
        recorder.close()
    # Complete: every step of the budget taken (OmniSafe ends only at the budget).
    run.update(complete=recorder.steps == args.steps, env_steps=recorder.steps, wall_seconds=float(recorder.wall()))
    write_json(os.path.join(out, "run.json"), run)
    print(
        f"omnisafe_saclag: {args.env} seed {args.seed}: {recorder.train.rows} training episodes, "
        f"{recorder.evals.rows} evaluation episodes, {recorder.steps} steps; last epoch's mean return "
        f"{float(ep_ret):.1f}, cost {float(ep_cost):.1f}, length {float(ep_len):.0f} -> {out}"
    )
    # The same folder as a run directory, for `defender report` beside our runs.
    convert(out, eval_every=10000)
    print(f"omnisafe_saclag: {out} is also a run directory (tools/peers/omnisafe_run_dir.py)")
    shutil.rmtree(checkpoints, ignore_errors=True)  # run.json says complete: no rerun reads it
    return 0


def start(args: argparse.Namespace, out: str) -> tuple:
    """OmniSafe's SACLag built by omnisafe.Agent, and the recorder hooked to it."""
    import omnisafe

    recorder = Recorder(out)
    hook_episodes(recorder)
    algo_cfgs: dict[str, int] = {"steps_per_epoch": args.steps_per_epoch}
    if args.start_learning_steps is not None:
        algo_cfgs["start_learning_steps"] = args.start_learning_steps
    custom_cfgs = {
        "seed": args.seed,
        "train_cfgs": {"total_steps": args.steps, "device": "cpu", "torch_threads": args.threads},
        "algo_cfgs": algo_cfgs,
        "lagrange_cfgs": {"cost_limit": args.cost_limit},
        "logger_cfgs": {"log_dir": out, "use_wandb": False},
    }
    algo = omnisafe.Agent("SACLag", args.env, custom_cfgs=custom_cfgs).agent
    # OmniSafe 0.5.0 seeds only the training environment: the evaluation one would draw its
    # initial states from OS entropy, and two runs of a seed differed in evals.csv. Seeded with the
    # run's seed, as other versions of OmniSafe's OnlineAdapter do; training is unchanged (this
    # draws on no generator training uses). Its reset also lets MuJoCo 2.3.3 pickle its MjData
    # (tools/peers/omnisafe_checkpoint.py).
    algo._env._eval_env.set_seed(args.seed)
    return algo, recorder


def resume(args: argparse.Namespace, out: str, meta: dict) -> tuple:
    """The algorithm as the checkpoint holds it (its files cut back already), the recorder going on
    from it, and the process set as OmniSafe sets it."""
    import omnisafe  # noqa: F401 (registers OmniSafe's environments and algorithms)
    import omnisafe_checkpoint as ck
    import torch
    from omnisafe.utils.tools import seed_all

    recorder = Recorder(out, resume=meta["recorder"])
    hook_episodes(recorder)
    _, state = ck.load(os.path.join(out, CHECKPOINT))
    algo = state["algo"]
    ck.reattach_logger(algo._logger, out, meta["log_dir"], meta["files"])
    # What omnisafe.Agent (threads, OMNISAFE_DEVICE) and BaseAlgo.__init__ (seed_all: also
    # torch.use_deterministic_algorithms) set for the process, then the generators as they were.
    torch.set_num_threads(args.threads)
    os.environ["OMNISAFE_DEVICE"] = "cpu"
    seed_all(args.seed)
    ck.set_rng_state(state["rng"])
    print(f"omnisafe_saclag: resuming {out} at epoch {meta['epoch']} ({meta['env_steps']} steps, "
          f"{recorder.train.rows} training and {recorder.evals.rows} evaluation episodes)")
    return algo, recorder


def read_previous(out: str) -> dict | str | None:
    """OUT's run.json (a run to resume or to refuse), None when OUT holds no run, or why OUT
    cannot be used."""
    path = os.path.join(out, "run.json")
    if not os.path.exists(path):
        if os.path.exists(os.path.join(out, "episodes.csv")):
            return f"{out}/episodes.csv exists without a run.json"
        return None
    try:
        with open(path, encoding="utf-8") as f:
            previous = json.load(f)
    except (OSError, ValueError) as e:
        return f"{path}: unreadable ({e})"
    return previous if isinstance(previous, dict) else f"{path}: not a JSON object"


if __name__ == "__main__":
    sys.exit(main())
