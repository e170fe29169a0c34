#!/usr/bin/env python3
"""Cost-labelled demonstrations of a navigation task from an OmniSafe learner's policy snapshots,
with `defender_rl.DemoRecorder(episode_cost_limit=25)`.

The paper's procedure (docs/SPEC.md section 13; `defender demos collect` on a cost task) records,
after each training episode, one episode of the learner's deterministic policy. For an on-policy
learner such as PPOLag the policy changes only at an epoch's end, so the policy after every
training episode of an epoch is that epoch's snapshot: recording `--per-snapshot` episodes of each
snapshot that tools/navigation/navigation_train.py kept (epoch 0, the initial policy, included) is the same
procedure with fewer episodes per policy. `DemoRecorder` labels and cuts them (unsafe: cut on the
step where the episode cost passed 25; safe: 1,000 steps within it), resets episode `k` with its
derived 32-bit seed (`defender_rl.demos.reset_seed(--seed, k)`; `k` counts the recorded episodes
over all snapshots), and `select` takes `--safe` + `--unsafe` at evenly spaced positions of each
group's candidates.

The policy: OmniSafe's actor from the snapshot (its `pi`), its mean action (OmniSafe's
deterministic `predict`) on the observation normalised by the snapshot's `obs_normalizer` (frozen:
OmniSafe's own Normalizer would go on updating its statistics), scaled from [-1, 1] to the task's
action space as OmniSafe's ActionScale does, clipped to it as the task's actuators clip.

Into --out (an .npz) and beside it --candidates (CSV): snapshot,episode,label,length,cost,return
of every recorded episode, kept or not. The set's provenance names the learner by its algorithm,
seed and budget, not by its folder (OmniSafe's carries the time it started), so that the same
snapshots give the same bytes wherever they were trained.

Run (in tools/peers/omnisafe-venv.sh's venv with the wheel installed), e.g.
  OMP_NUM_THREADS=1 nice -n 10 .deps/omnisafe-venv/bin/python tools/navigation/navigation_demos.py \\
      --run results/navigation/SafetyPointGoal1-v0/ppolag-s0 --per-snapshot 10 --safe 25 --unsafe 25 \\
      --seed 0 --out runs/navigation/SafetyPointGoal1-v0-demos.npz --candidates results/navigation/.../candidates.csv
"""

from __future__ import annotations

import argparse
import csv
import glob
import json
import os
import re
import sys
import warnings

import numpy as np


def snapshots(run: str) -> tuple[str, list[tuple[int, str]]]:
    """The OmniSafe log folder under a tools/navigation/navigation_train.py --out, and its policy snapshots
    (epoch, path) in epoch order."""
    folders = sorted(glob.glob(os.path.join(run, "*", "seed-*")))
    if len(folders) != 1:
        raise SystemExit(
            f"navigation_demos: {run}: expected one OmniSafe log folder <ALGO>-<task>/seed-*, found {folders}"
        )
    found = []
    for path in glob.glob(os.path.join(folders[0], "torch_save", "epoch-*.pt")):
        m = re.fullmatch(r"epoch-(\d+)\.pt", os.path.basename(path))
        if m:
            found.append((int(m.group(1)), path))
    if not found:
        raise SystemExit(f"navigation_demos: {folders[0]}/torch_save holds no epoch-*.pt")
    return folders[0], sorted(found)


class SnapshotPolicy:
    """OmniSafe's deterministic policy of one snapshot, as a function of the task's raw
    observation to the action the task executes."""

    def __init__(self, cfgs: dict, path: str, obs_space, act_space) -> None:  # noqa: ANN001 (gymnasium Boxes)
        import torch
        from omnisafe.models.actor.actor_builder import ActorBuilder

        params = torch.load(path)
        model = cfgs["model_cfgs"]
        self._actor = ActorBuilder(
            obs_space=obs_space,
            act_space=act_space,
            hidden_sizes=model["actor"]["hidden_sizes"],
            activation=model["actor"]["activation"],
            weight_initialization_mode=model["weight_initialization_mode"],
        ).build_actor(model["actor_type"])
        self._actor.load_state_dict(params["pi"])
        self._norm = None
        if cfgs["algo_cfgs"].get("obs_normalize"):
            state = params["obs_normalizer"]
            # OmniSafe's Normalizer returns the raw observation until it has seen two.
            if int(state["_count"]) > 1:
                self._norm = (state["_mean"].double(), state["_std"].double(), state["_clip"].double())
        self._low, self._high = np.asarray(act_space.low), np.asarray(act_space.high)
        self._torch = torch

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        torch = self._torch
        x = torch.as_tensor(np.asarray(obs, dtype=np.float64))
        if self._norm is not None:
            mean, std, clip = self._norm
            x = torch.clamp((x - mean) / std, -clip, clip)
        with torch.no_grad():
            a = self._actor.predict(x.float(), deterministic=True).double().numpy()
        # OmniSafe's ActionScale from [-1, 1] to the task's bounds, then the actuators' clip.
        a = self._low + (self._high - self._low) * (a + 1.0) / 2.0
        return np.clip(a, self._low, self._high)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", required=True, help="a tools/navigation/navigation_train.py --out folder")
    parser.add_argument("--per-snapshot", type=int, required=True, help="episodes recorded per snapshot")
    parser.add_argument("--safe", type=int, required=True, help="safe demonstrations to keep")
    parser.add_argument("--unsafe", type=int, required=True, help="unsafe demonstrations to keep")
    parser.add_argument("--seed", type=int, default=0, help="DemoRecorder's seed (reset seeds derive from it)")
    parser.add_argument("--cost-limit", type=float, default=25.0)
    parser.add_argument("--out", required=True, help="the demonstration set (.npz)")
    parser.add_argument("--candidates", required=True, help="every recorded episode (CSV)")
    args = parser.parse_args(argv)
    if min(args.per_snapshot, args.safe, args.unsafe) <= 0:
        parser.error("--per-snapshot, --safe and --unsafe must be positive")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium-robotics' notice about its Adroit tasks
        import safety_gymnasium
        from safety_gymnasium.wrappers import SafetyGymnasium2Gymnasium
    from defender_rl import DemoRecorder

    folder, snaps = snapshots(args.run)
    with open(os.path.join(folder, "config.json"), encoding="utf-8") as f:
        cfgs = json.load(f)
    task = cfgs["env_id"]
    env = SafetyGymnasium2Gymnasium(safety_gymnasium.make(task))
    recorder = DemoRecorder(env, seed=args.seed, episode_cost_limit=args.cost_limit)
    rows = []
    k = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # DemoRecorder's note on episodes of neither group (none here)
        for epoch, path in snaps:
            policy = SnapshotPolicy(cfgs, path, env.observation_space, env.action_space)
            for _ in range(args.per_snapshot):
                kept = len(recorder.candidates)
                unsafe = recorder.record(policy, after_episode=k)
                if len(recorder.candidates) > kept:
                    obs, act, rew, _ = recorder.candidates[-1]
                    rows.append([epoch, k, "unsafe" if unsafe else "safe", len(rew), repr(float(rew.sum()))])
                else:
                    rows.append([epoch, k, "neither", recorder.left_out[-1], ""])
                k += 1
            sizes = recorder.group_sizes
            print(f"navigation_demos: epoch {epoch}: (safe, unsafe) candidates so far {sizes}", flush=True)
    with open(args.candidates, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["snapshot_epoch", "episode", "label", "recorded_steps", "return"])
        w.writerows(rows)
    provenance = (
        f"tools/navigation/navigation_demos.py: defender_rl.DemoRecorder (seed {args.seed}) on {task}, {args.per_snapshot} "
        f"episodes of the deterministic policy of each of {len(snaps)} snapshots (epochs {snaps[0][0]}-{snaps[-1][0]}) "
        f"of OmniSafe {cfgs['algo']} seed {cfgs['seed']}, {cfgs['train_cfgs']['total_steps']} steps "
        f"({len(recorder.candidates)} candidates; unsafe: cut on the step where the "
        f"episode cost passed {args.cost_limit:g}; safe: reached the horizon with cost <= {args.cost_limit:g})"
    )
    demos = recorder.select(args.safe, args.unsafe, provenance=provenance)
    demos.save(args.out)
    print(f"navigation_demos: {task}: {args.safe} + {args.unsafe} of {recorder.group_sizes} candidates -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
