#!/usr/bin/env python3
"""Train OmniSafe 0.5.0's PPOLag (or SACLag) on a bare Safety-Gymnasium navigation task, keep a
snapshot of its policy every epoch, and record every training episode for the offline screen.

The learner of docs/results-navigation.md: OmniSafe's own agent with its defaults for the task
(the task's section of its yaml, when it has one) and the cost limit 25, through `omnisafe.Agent`,
one CPU thread. Two things are added, neither changing what OmniSafe does:

  * every environment step of training, as the task took it, is recorded: OmniSafe's
    `SafetyGymnasiumEnv.step`/`reset` (the CMDP under all of OmniSafe's wrappers) are wrapped, so
    the observations are the task's own (before OmniSafe's observation normalisation), the
    actions those the task executed (after OmniSafe's action scaling, clipped to the task's
    action space as its actuators clip them), and the costs `info["cost"]`. The episodes are
    labelled and cut by docs/SPEC.md section 13 (tools/navigation/navigation_episodes.py) into
    OUT/episodes.npz, the input `defender screen --episodes` takes, with `meta`
    episode_cost_limit;
  * OmniSafe saves its policy every `--save-every` epochs (its `logger_cfgs.save_model_freq`;
    OmniSafe also saves the initial policy, epoch 0) into OUT/<ALGO>-<task>/seed-.../torch_save/,
    which tools/navigation/navigation_demos.py reads to record demonstrations.

Into --out:
  episodes.csv   episode,total_steps,return,length,cost,wall_seconds (tools/peers/omnisafe_saclag.py's
                 recorder: every training episode as OmniSafe sums it)
  labels.csv     episode,label,length,return,cost,recorded_steps,first_cost_step: the same
                 episodes by section 13's rule (safe / unsafe / neither; recorded_steps: kept in
                 episodes.npz; first_cost_step: the 0-based step of its first cost, -1: none)
  episodes.npz   the kept episodes (git ignores .npz under results/: this command remakes it)
  run.json       the arguments, versions, the label counts; "complete": true at the end
  <ALGO>-<task>/seed-SSS-.../   OmniSafe's own logs (progress.csv, config.json) and torch_save/

Run (in tools/peers/omnisafe-venv.sh's venv with the wheel installed), e.g.
  OMP_NUM_THREADS=1 nice -n 10 .deps/omnisafe-venv/bin/python tools/navigation/navigation_train.py \\
      --env SafetyPointGoal1-v0 --seed 0 --steps 100000 --out results/navigation/SafetyPointGoal1-v0/ppolag-s0
The budget must be a multiple of --steps-per-epoch (OmniSafe's rule; PPOLag's default 20,000, a
whole number of 1,000-step episodes, so that no epoch cuts an episode).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(HERE), "peers")]  # this folder, and tools/peers/
from navigation_episodes import CostLabelledEpisodes  # noqa: E402 (beside this file)
from navigation_layout import TASKS  # noqa: E402 (the tasks whose observation layout is known)
from omnisafe_run_dir import write_json  # noqa: E402
from omnisafe_saclag import Recorder, hook_episodes, versions  # noqa: E402

ALGOS = {"PPOLag": 20000, "SACLag": 2000}  # OmniSafe 0.5.0's steps_per_epoch for each
HORIZON = 1000  # the navigation tasks' time limit


def hook_steps(limit: float) -> list[CostLabelledEpisodes]:
    """Wraps OmniSafe's `SafetyGymnasiumEnv.reset`/`step` so that every instance's steps go to a
    `CostLabelledEpisodes` of its own; returns the list of them (one per instance that was reset
    or stepped). OmniSafe's adapter builds a training and an evaluation instance; PPOLag never
    steps the latter, SACLag does (its evaluation episodes: not training, told apart by the
    caller)."""
    import torch
    from omnisafe.envs.safety_gymnasium_env import SafetyGymnasiumEnv

    logs: list[CostLabelledEpisodes] = []
    reset, step = SafetyGymnasiumEnv.reset, SafetyGymnasiumEnv.step

    def log_of(env) -> CostLabelledEpisodes:  # noqa: ANN001
        if not hasattr(env, "_navigation_log"):
            env._navigation_log = CostLabelledEpisodes(limit, HORIZON)
            logs.append(env._navigation_log)
        return env._navigation_log

    def _reset(self, seed=None, options=None):  # noqa: ANN001, ANN202 (OmniSafe's signature)
        obs, info = reset(self, seed=seed, options=options)
        log_of(self).begin(obs.numpy())
        return obs, info

    def _step(self, action: torch.Tensor):  # noqa: ANN202
        if self._num_envs != 1:
            raise RuntimeError("navigation_train records one environment (train_cfgs.vector_env_nums = 1)")
        space = self._action_space
        executed = np.clip(action.detach().cpu().numpy().astype(np.float64), space.low, space.high)
        obs, reward, cost, terminated, truncated, info = step(self, action)
        done = bool(terminated) or bool(truncated)
        # Safety-Gymnasium's own autoreset (OmniSafe makes the task with autoreset=True) has
        # already begun the next episode: `obs` is its first observation, the episode's last one
        # is info["final_observation"].
        last = info["final_observation"] if done else obs
        log = log_of(self)
        log.step(executed, float(reward), float(cost), np.asarray(last, dtype=np.float64).reshape(-1), done)
        if done:
            log.begin(obs.numpy())
        return obs, reward, cost, terminated, truncated, info

    SafetyGymnasiumEnv.reset, SafetyGymnasiumEnv.step = _reset, _step
    return logs


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", required=True, choices=TASKS, help="Safety-Gymnasium navigation task")
    parser.add_argument("--algo", default="PPOLag", choices=sorted(ALGOS), help="OmniSafe's agent (default PPOLag)")
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--steps", type=int, required=True, help="environment steps of training")
    parser.add_argument("--out", required=True, help="output folder (created; must not hold episodes.csv)")
    parser.add_argument("--cost-limit", type=float, default=25.0, help="the Lagrangian's and the labels' limit (25)")
    parser.add_argument("--steps-per-epoch", type=int, help="default: OmniSafe's (PPOLag 20000, SACLag 2000)")
    parser.add_argument("--update-iters", type=int, help="PPOLag: passes over each epoch's data (OmniSafe's 40)")
    parser.add_argument("--save-every", type=int, default=1, help="epochs between policy snapshots (default 1)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (default 1: one core)")
    args = parser.parse_args(argv)
    if args.steps_per_epoch is None:
        args.steps_per_epoch = ALGOS[args.algo]
    if args.steps <= 0 or args.steps_per_epoch <= 0 or args.steps % args.steps_per_epoch:
        parser.error(f"--steps {args.steps}: must be a positive multiple of --steps-per-epoch {args.steps_per_epoch}")
    if args.cost_limit <= 0 or args.save_every <= 0:
        parser.error("--cost-limit and --save-every must be positive")
    if args.update_iters is not None and args.algo != "PPOLag":
        parser.error("--update-iters is PPOLag's")
    return args


def custom_cfgs(args: argparse.Namespace, out: str) -> dict:
    """OmniSafe's settings: the task's own section of the algorithm's yaml, then ours."""
    from omnisafe_defender import merge
    from omnisafe_defender_env import task_cfgs

    algo_cfgs: dict[str, int] = {"steps_per_epoch": args.steps_per_epoch}
    if args.update_iters is not None:
        algo_cfgs["update_iters"] = args.update_iters
    ours = {
        "seed": args.seed,
        "train_cfgs": {"total_steps": args.steps, "device": "cpu", "torch_threads": args.threads},
        "algo_cfgs": algo_cfgs,
        "lagrange_cfgs": {"cost_limit": args.cost_limit},
        "logger_cfgs": {"log_dir": out, "use_wandb": False, "save_model_freq": args.save_every},
    }
    return merge(task_cfgs(args.algo, args.env), ours)


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    if os.path.exists(os.path.join(out, "episodes.csv")):
        print(f"navigation_train: {out}/episodes.csv exists; choose another --out", file=sys.stderr)
        return 2

    import omnisafe
    from omnisafe.adapter.offpolicy_adapter import OffPolicyAdapter
    from omnisafe.adapter.onpolicy_adapter import OnPolicyAdapter

    run = {"algo": args.algo, **vars(args), "versions": versions(), "complete": False}
    write_json(os.path.join(out, "run.json"), run)
    recorder = Recorder(out)
    hook_episodes(recorder, OffPolicyAdapter if args.algo == "SACLag" else OnPolicyAdapter)
    logs = hook_steps(args.cost_limit)
    try:
        agent = omnisafe.Agent(args.algo, args.env, custom_cfgs=custom_cfgs(args, out))
        agent.learn()
    finally:
        recorder.close()
    # The training instance is the one that took the budget's steps (SACLag's evaluation
    # instance takes a few episodes' worth).
    training = max(logs, key=lambda log: sum(row[1] for row in log.rows))
    steps = sum(row[1] for row in training.rows)
    with open(os.path.join(out, "labels.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["episode", "label", "length", "return", "cost", "recorded_steps", "first_cost_step"])
        for i, (label, length, ret, cost, kept, first) in enumerate(training.rows):
            w.writerow([i, label, length, repr(ret), repr(cost), kept, first])
    provenance = (
        f"tools/navigation/navigation_train.py: every training episode of OmniSafe {args.algo} on {args.env}, seed {args.seed}, "
        f"{args.steps} steps; unsafe: cut on the step where the episode cost passed {args.cost_limit:g}; safe: reached "
        f"the horizon of {HORIZON} steps with cost <= {args.cost_limit:g}"
    )
    training.episode_set(args.env, provenance, training_steps=args.steps, seed=args.seed).save(
        os.path.join(out, "episodes.npz")
    )
    run.update(
        complete=recorder.steps == args.steps == steps,
        env_steps=recorder.steps,
        wall_seconds=float(recorder.wall()),
        labels=training.counts,
    )
    write_json(os.path.join(out, "run.json"), run)
    print(
        f"navigation_train: {args.algo} on {args.env} seed {args.seed}: {steps} steps, "
        f"episodes {training.counts} -> {out}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
