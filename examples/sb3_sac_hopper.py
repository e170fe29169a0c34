"""Stable-Baselines3 SAC on Gymnasium's own Hopper-v5, with DEFENDER and the shipped
demonstrations (data/demos/Hopper-v5.npz), or bare for comparison.

    pip install ".[sb3]" "gymnasium[mujoco]"      # or: make python && pip install -r python/requirements-sb3.txt
    python examples/sb3_sac_hopper.py --steps 20000                  # with DEFENDER
    python examples/sb3_sac_hopper.py --steps 20000 --bare           # without
    python examples/sb3_sac_hopper.py --strategy auto                 # strategy chosen from the demonstrations
    python examples/sb3_sac_hopper.py --tensorboard runs/tb          # crash/filter rates in TensorBoard

It prints the training episodes' crash rate (episodes the environment terminated: the hopper
fell) and, with DEFENDER, the share of episodes the filter ended instead; at the end it saves the
agent and, beside it, the wrapper's state (dynamics model and counters).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import gymnasium as gym
from stable_baselines3 import SAC
from stable_baselines3.common.monitor import Monitor

from defender_rl import DefenderWrapper
from defender_rl.sb3 import DefenderCallback

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="Hopper-v5")
    p.add_argument("--demos", default=None, help="default: data/demos/<ENV>.npz")
    p.add_argument("--strategy", default="MeanDemoW5/MeanDemoW10",
                   help="SAFE/UNSAFE, or auto: chosen from the demonstrations as `defender train --strategy auto`")
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--bare", action="store_true", help="train without DEFENDER")
    p.add_argument("--dynamics-thread", action="store_true", help="train the dynamics model on its own thread")
    p.add_argument("--tensorboard", default=None, help="TensorBoard log folder")
    p.add_argument("--out", default=None, help="save the agent (and the wrapper's state) here")
    args = p.parse_args()

    env = gym.make(args.env)
    if not args.bare:
        demos = args.demos or ROOT / "data" / "demos" / f"{args.env}.npz"
        env = DefenderWrapper(env, demos, args.strategy, seed=args.seed,
                              dynamics={"background": args.dynamics_thread})
        if env.strategy_selection is not None:
            chosen = env.strategy_selection
            print(f"strategy auto: {env.strategy} on scaling {chosen['scaling']} of {chosen['candidates']} "
                  f"strategies x {len(chosen['scalings']) or 1} scaling(s) in {chosen['seconds']:.1f}s "
                  f"(held-out false alarms {100 * chosen['false_alarm_rate']:.0f}%, "
                  f"crashes prevented {100 * chosen['crash_prevention_rate']:.0f}%)")
        env = Monitor(env, info_keywords=("defender_outcome",))
    else:
        env = Monitor(env)
    callback = DefenderCallback()
    model = SAC("MlpPolicy", env, seed=args.seed, verbose=0, tensorboard_log=args.tensorboard)
    start = time.perf_counter()
    model.learn(total_timesteps=args.steps, callback=callback if not args.bare else None, log_interval=20)
    seconds = time.perf_counter() - start

    lengths = env.get_episode_lengths()  # one per finished episode
    label = "bare" if args.bare else f"DEFENDER {env.env.strategy}"
    if args.bare:
        # Without the wrapper, a crash is an episode that ended before the time limit.
        limit = env.spec.max_episode_steps if env.spec else None
        crashes = sum(1 for n in lengths if limit is None or n < limit)
        print(f"{args.env} SAC {label}: {args.steps} steps, {len(lengths)} episodes, "
              f"crash {100 * crashes / max(len(lengths), 1):.1f}%, {seconds:.1f}s")
    else:
        stats = env.env.defender_stats
        print(f"{args.env} SAC {label}: {args.steps} steps, {stats['episodes']} episodes, "
              f"crash {100 * stats['crashed_episodes'] / max(stats['episodes'], 1):.1f}%, "
              f"filtered {100 * stats['filtered_episodes'] / max(stats['episodes'], 1):.1f}%, {seconds:.1f}s")
    if args.out:
        out = pathlib.Path(args.out)
        model.save(out / "sac")
        if not args.bare:
            env.env.save_state(out / "defender")
        print(f"saved to {out}")


if __name__ == "__main__":
    main()
