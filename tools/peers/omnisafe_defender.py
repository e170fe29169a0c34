#!/usr/bin/env python3
"""Train OmniSafe 0.5.0's SACLag or PPOLag on a DEFENDER-wrapped Safety-Gymnasium task.

The environment is `Defender-<task>` of tools/peers/omnisafe_defender_env.py: the task under
`defender_rl.DefenderWrapper` with its demonstrations (data/demos/<task>.npz, or --demos) and the
episode cost limit 25, registered with OmniSafe as a CMDP; the agent is OmniSafe's own,
`omnisafe.Agent(ALGO, "Defender-<task>", custom_cfgs=...)`, with OmniSafe's defaults for ALGO
(and for the task: a section of ALGO's yaml for the bare task, such as SACLag.yaml's
SafetyPointGoal1-v0, is applied too) and the cost limit 25. What the agent sees on a filtered step
and how it is evaluated (the bare task): that module's docstring, docs/peers.md ("OmniSafe's
agents on a DEFENDER-wrapped task").

Into --out (beside OmniSafe's own logs, {ALGO}-{Defender-<task>}/seed-SSS-.../progress.csv ...):

  episodes.csv          every training episode as it ends, as tools/peers/omnisafe_saclag.py writes it
                        (its recorder): episode,total_steps,return,length,cost,wall_seconds; the
                        return and cost OmniSafe sums, a filtered step's R_task and cost 0 included
  evals.csv             every evaluation episode (SACLag: one an epoch, on the bare task; PPOLag
                        evaluates none: the header only)
  defender_episodes.csv episode,total_steps,outcome,length,cost: the same episodes from the
                        wrapper's side; outcome crashed (the task terminated it), filtered (DEFENDER
                        ended it) or truncated (the horizon)
  defender.json         when training ends: the wrapper's counters (defender_stats), the strategy
                        (and strategy="auto"'s selection), R_task, the filter's state, the dynamics
                        model's counters, the demonstrations
OmniSafe's progress.csv also has, per epoch, Defender/Filtered, Defender/Crashed and
Defender/Truncated: the shares of the epoch's finished episodes with each outcome.
  run.json              the arguments, versions (defender-rl's too); "complete": true at the end

Run (after `bash tools/peers/omnisafe-venv.sh` and `pip install dist/defender_rl-*.whl` into it), e.g.
  .deps/omnisafe-venv/bin/python tools/peers/omnisafe_defender.py --algo SACLag \\
      --env SafetyHopperVelocity-v1 --seed 0 --steps 300000 --out runs/omnisafe-defender/hopper-s0
The budget must be a multiple of --steps-per-epoch (OmniSafe's rule; its defaults: SACLag 2,000,
PPOLag 20,000). --strategy auto (the default, as `defender train`'s default arm) ranks the
strategies on the demonstrations first: about 1.5 minutes per scaling on SafetyHopperVelocity-v1's
set; --strategy MinBothW5/MinBothW10 (what it chose there) starts at once.
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib import metadata

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from omnisafe_run_dir import write_json  # noqa: E402 (tools/peers/ beside this file)
from omnisafe_saclag import EpisodeCsv, Recorder, hook_episodes, versions  # noqa: E402

ALGOS = {"SACLag": 2000, "PPOLag": 20000}  # OmniSafe 0.5.0's steps_per_epoch for each
DEFENDER_EPISODE_HEADER = ["episode", "total_steps", "outcome", "length", "cost"]


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    from omnisafe_defender_env import TASKS  # imports OmniSafe and torch (seconds)

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", required=True, choices=sorted(ALGOS), help="OmniSafe's agent")
    parser.add_argument("--env", required=True, help=f"Safety-Gymnasium task: one of {', '.join(TASKS)}")
    parser.add_argument("--seed", type=int, required=True, help="OmniSafe's seed (also DEFENDER's dynamics model's)")
    parser.add_argument("--steps", type=int, required=True, help="environment steps of training (filtered ones included)")
    parser.add_argument("--out", required=True, help="output folder (created; must not hold episodes.csv)")
    parser.add_argument("--demos", help="demonstrations (.npz labelled by the cost limit); default: data/demos/<task>.npz")
    parser.add_argument("--strategy", default="auto", help="DefenderWrapper's strategy (default auto)")
    parser.add_argument("--scaling", choices=("none", "zscore"), help="DTW's scaling (default: the wrapper's)")
    parser.add_argument(
        "--cost-limit", type=float, default=25.0,
        help="per-episode cost limit: OmniSafe's Lagrangian's and the wrapper's episode_cost_limit (default 25)",
    )
    parser.add_argument("--steps-per-epoch", type=int, help="default: OmniSafe's (SACLag 2000, PPOLag 20000)")
    parser.add_argument("--start-learning-steps", type=int, help="SACLag: random steps first (OmniSafe's default 10000)")
    parser.add_argument("--update-iters", type=int, help="PPOLag: passes over each epoch's data (OmniSafe's default 40)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (default 1: one core a run)")
    args = parser.parse_args(argv)

    if args.env.startswith("Defender-"):
        args.env = args.env[len("Defender-"):]
    if args.env not in TASKS:
        parser.error(f"--env {args.env}: one of {', '.join(TASKS)}")
    if args.steps_per_epoch is None:
        args.steps_per_epoch = ALGOS[args.algo]
    if args.steps <= 0 or args.steps_per_epoch <= 0 or args.steps % args.steps_per_epoch:
        parser.error(f"--steps {args.steps}: must be a positive multiple of --steps-per-epoch {args.steps_per_epoch}")
    if args.cost_limit <= 0:
        parser.error(f"--cost-limit {args.cost_limit}: must be positive")
    if args.start_learning_steps is not None and args.algo != "SACLag":
        parser.error("--start-learning-steps is SACLag's")
    if args.update_iters is not None and args.algo != "PPOLag":
        parser.error("--update-iters is PPOLag's")
    if args.demos is not None and not os.path.isfile(args.demos):
        parser.error(f"--demos {args.demos}: no such file")
    return args


def custom_cfgs(args: argparse.Namespace, out: str, task_cfgs: dict) -> dict:
    """OmniSafe's settings: the task's own section of the algorithm's yaml, then ours."""
    algo_cfgs: dict[str, int] = {"steps_per_epoch": args.steps_per_epoch}
    if args.start_learning_steps is not None:
        algo_cfgs["start_learning_steps"] = args.start_learning_steps
    if args.update_iters is not None:
        algo_cfgs["update_iters"] = args.update_iters
    ours = {
        "seed": args.seed,
        "train_cfgs": {"total_steps": args.steps, "device": "cpu", "torch_threads": args.threads},
        "algo_cfgs": algo_cfgs,
        "lagrange_cfgs": {"cost_limit": args.cost_limit},
        "logger_cfgs": {"log_dir": out, "use_wandb": False},
    }
    return merge(task_cfgs, ours)


def merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    if os.path.exists(os.path.join(out, "episodes.csv")):
        print(f"omnisafe_defender: {out}/episodes.csv exists; choose another --out", file=sys.stderr)
        return 2

    import omnisafe
    from omnisafe.adapter.offpolicy_adapter import OffPolicyAdapter
    from omnisafe.adapter.onpolicy_adapter import OnPolicyAdapter

    import omnisafe_defender_env as defender_env

    wrapper: dict = {"strategy": args.strategy, "episode_cost_limit": args.cost_limit}
    if args.scaling is not None:
        wrapper["scaling"] = args.scaling
    env_id = defender_env.configure(args.env, args.demos, **wrapper)
    demos = os.path.abspath(args.demos or defender_env.shipped_demos(args.env))

    vers = versions()
    try:
        vers["defender-rl"] = metadata.version("defender-rl")
    except metadata.PackageNotFoundError:
        vers["defender-rl"] = "not installed"
    run = {"algo": args.algo, "omnisafe_env": env_id, **vars(args), "demos": demos, "versions": vers, "complete": False}
    write_json(os.path.join(out, "run.json"), run)

    recorder = Recorder(out)
    hook_episodes(recorder, OffPolicyAdapter if args.algo == "SACLag" else OnPolicyAdapter)
    outcomes = EpisodeCsv(os.path.join(out, "defender_episodes.csv"), DEFENDER_EPISODE_HEADER)

    def on_episode(env, outcome: str, length: int, cost: float, steps: int) -> None:  # noqa: ANN001
        outcomes.write([outcomes.rows, steps, outcome, length, repr(cost)])

    defender_env.episode_listeners.append(on_episode)
    cfgs = custom_cfgs(args, out, defender_env.task_cfgs(args.algo, args.env))
    try:
        agent = omnisafe.Agent(args.algo, env_id, custom_cfgs=cfgs)
        ep_ret, ep_cost, ep_len = agent.learn()
    finally:
        recorder.close()
        outcomes.close()
    (training,) = [e for e in defender_env.environments if e.defender is not None]
    summary = {"env": args.env, "omnisafe_env": env_id, **training.summary()}
    write_json(os.path.join(out, "defender.json"), summary)
    run.update(complete=recorder.steps == args.steps, env_steps=recorder.steps, wall_seconds=float(recorder.wall()))
    write_json(os.path.join(out, "run.json"), run)
    stats = summary["defender_stats"]
    print(
        f"omnisafe_defender: {args.algo} on {env_id} seed {args.seed}: {recorder.train.rows} training episodes "
        f"({stats['filtered_episodes']} filtered, {stats['crashed_episodes']} crashed, "
        f"{stats['truncated_episodes']} truncated), {recorder.steps} steps ({stats['filtered_steps']} filtered), "
        f"{recorder.evals.rows} evaluation episodes; last epoch's mean return {float(ep_ret):.1f}, "
        f"cost {float(ep_cost):.1f}, length {float(ep_len):.0f} -> {out}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
