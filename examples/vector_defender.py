"""DEFENDER under a Gymnasium vector environment (`gym.make_vec`, several sub-environments),
with its crash and filter rates in TensorBoard. The policy here acts at random so that the
example runs without PyTorch: put your agent's action where it says `policy`.

    pip install ".[mujoco]" tensorboard            # or: make python
    python examples/vector_defender.py --env-id Hopper-v5 --num-envs 4 --total-timesteps 20000
    tensorboard --logdir runs/vector

Every step's `info` carries `defender_filtered`, `defender_safe_cost` and
`defender_unsafe_cost` for every sub-environment, also on a step where one resets (there they
are neutral: False and NaN); an episode's last step carries `defender_outcome`. Under the
default next-step autoreset that last step's `info` is the step's own; under same-step
autoreset (`--autoreset same-step`) it is in `info["final_info"]`.
"""

from __future__ import annotations

import argparse
import pathlib
import time
from collections import deque

import gymnasium as gym
import numpy as np
from tensorboard.summary import Writer

from defender_rl import DefenderWrapper

ROOT = pathlib.Path(__file__).resolve().parents[1]


def parse_args():
    p = argparse.ArgumentParser()
    p.add_argument("--env-id", default="Hopper-v5")
    p.add_argument("--num-envs", type=int, default=4)
    p.add_argument("--total-timesteps", type=int, default=20_000, help="steps over all sub-environments")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--strategy", default="MeanDemoW5/MeanDemoW10")
    p.add_argument("--demos", default=None, help="default: data/demos/<ENV>.npz")
    p.add_argument("--vectorization", choices=["sync", "async"], default="sync")
    p.add_argument("--autoreset", choices=["next-step", "same-step"], default="next-step")
    p.add_argument("--logdir", default="runs/vector")
    return p.parse_args()


def outcomes(info: dict, mode: gym.vector.AutoresetMode) -> list[str]:
    """The outcomes of the episodes that ended on this step."""
    src = info.get("final_info", {}) if mode == gym.vector.AutoresetMode.SAME_STEP else info
    if "defender_outcome" not in src:
        return []
    return [o for o, m in zip(src["defender_outcome"], src["_defender_outcome"]) if m]


def main():
    args = parse_args()
    demos = args.demos or str(ROOT / "data" / "demos" / f"{args.env_id}.npz")
    mode = gym.vector.AutoresetMode.SAME_STEP if args.autoreset == "same-step" else gym.vector.AutoresetMode.NEXT_STEP
    envs = gym.make_vec(
        args.env_id,
        num_envs=args.num_envs,
        vectorization_mode=args.vectorization,
        # One wrapper per sub-environment, built in its own process with "async": a function,
        # not a built wrapper, goes to the workers.
        wrappers=[lambda env: DefenderWrapper(env, demos, args.strategy, seed=args.seed)],
        vector_kwargs={"autoreset_mode": mode},
    )
    run = pathlib.Path(args.logdir) / f"{args.env_id}__{args.strategy.replace('/', '-')}__{args.seed}__{int(time.time())}"
    writer = Writer(str(run))
    envs.action_space.seed(args.seed)
    envs.reset(seed=args.seed)
    recent: deque[str] = deque(maxlen=100)
    counts = {"crashed": 0, "filtered": 0, "truncated": 0}
    filtered_steps = 0
    step = 0
    while step < args.total_timesteps:
        action = envs.action_space.sample()  # policy: your agent's actions for every sub-environment
        _, _, _, _, info = envs.step(action)
        step += args.num_envs
        filtered_steps += int(np.sum(info["defender_filtered"]))
        for outcome in outcomes(info, mode):
            counts[outcome] += 1
            recent.append(outcome)
            episodes = sum(counts.values())
            writer.add_scalar("defender/crash_rate", counts["crashed"] / episodes, step)
            writer.add_scalar("defender/filter_rate", counts["filtered"] / episodes, step)
            writer.add_scalar("defender/crash_rate_recent", recent.count("crashed") / len(recent), step)
            writer.add_scalar("defender/filter_rate_recent", recent.count("filtered") / len(recent), step)
        costs = info["defender_safe_cost"][np.isfinite(info["defender_safe_cost"])]
        if step % (100 * args.num_envs) == 0:
            writer.add_scalar("defender/filtered_step_rate", filtered_steps / step, step)
            if costs.size:
                writer.add_scalar("defender/mean_safe_cost", float(costs.mean()), step)
    writer.close()
    envs.close()
    episodes = sum(counts.values())
    print(
        f"{args.env_id}, {args.num_envs} envs, {step} steps: {episodes} episodes, "
        f"crashed {counts['crashed']}, filtered {counts['filtered']}; TensorBoard: {run}"
    )


if __name__ == "__main__":
    main()
