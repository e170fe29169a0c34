#!/usr/bin/env python3
"""Record Gymnasium 1.4.0 MuJoCo rollouts as parity test data for defender-mujoco.

For each task (Hopper-v5, Walker2d-v5, InvertedDoublePendulum-v5, and the v4 tasks that
Safety-Gymnasium's velocity tasks wrap: Hopper-v4, Walker2d-v4, HalfCheetah-v4) this starts
Gymnasium's own environment from several initial states, applies several action patterns (zeros,
a sinusoid, uniform actions inside the box, large actions far outside it, constant maximal torque)
and records, step by step, the observation, the reward, the `terminated` flag and, where the task
reports it, `info["x_velocity"]`, stopping after the first terminated step. The x-velocity is what
Safety-Gymnasium's velocity cost reads (`float(x_velocity > threshold)`); the tests check the cost
of SafetyHopperVelocity-v1 etc. against it (safety-gymnasium itself needs MuJoCo 2.3.3 and an older
Gymnasium, so its rollouts would not be Gymnasium 1.4.0's). The Rust tests (crates/defender-mujoco/tests/parity.rs) replay the same
initial states and actions and require every value to agree within 1e-6.

How a case starts, exactly as `defender_mujoco::replay` does: `env.reset(seed)`, then
`mj_resetData` (so that no solver warm start or time is left from the random reset state), then
`set_state(qpos, qvel)` (which runs `mj_forward`); the first observation is `_get_obs()`. Actions
are float64 and go to `env.unwrapped.step` unchanged (Gymnasium does not clip them; MuJoCo clamps
`ctrl` to `ctrlrange` inside the physics, and the control cost sees the raw action).

Output, in crates/defender-mujoco/tests/data/:
  <task>.npz          per case i: case{i}_qpos [nq], case{i}_qvel [nv], case{i}_actions [T, nu],
                      case{i}_obs [T'+1, obs_dim], case{i}_rew [T'], case{i}_terminated [T'] (bool),
                      case{i}_x_velocity [T'] (tasks whose info has it: not the pendulum),
                      with T' <= T the number of steps up to and including the first termination;
                      plus `cases` (the count). Cases are initial states (Gymnasium's reset for
                      seeds 0 and 1, a strongly perturbed one, a fast one) times action patterns
                      (zeros, sine, uniform, large, max), in that order: case 3 is reset0/large.
                      HalfCheetah-v4 never terminates: its cases run all T = 100 steps.
  cli_hopper_{qpos,qvel,actions}.npy and cli_hopper_expected.npz: one Hopper case as separate
                      .npy files, as numpy writes them, for the `defender env replay` end-to-end test.

Needs gymnasium[mujoco]==1.4.0 (gymnasium.envs.mujoco imports imageio and packaging).
Run (from the repository root, after `make tools-venv`):
  .deps/tools-venv/bin/python tools/golden/gym_record.py [--tasks Hopper-v4 ...]
"""

from __future__ import annotations

import argparse
import os

import gymnasium as gym
import mujoco
import numpy as np

TASKS = {
    "Hopper-v5": "hopper_v5",
    "Walker2d-v5": "walker2d_v5",
    "InvertedDoublePendulum-v5": "inverted_double_pendulum_v5",
    "Hopper-v4": "hopper_v4",
    "Walker2d-v4": "walker2d_v4",
    "HalfCheetah-v4": "half_cheetah_v4",
}


def action_patterns(nu: int, steps: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Action sequences [steps, nu], float64."""
    t = np.arange(steps, dtype=np.float64)[:, None]
    j = np.arange(nu, dtype=np.float64)[None, :]
    return {
        "zeros": np.zeros((steps, nu)),
        "sine": 0.5 * np.sin(0.1 * t + j),
        "uniform": rng.uniform(-1.0, 1.0, size=(steps, nu)),
        # Far outside the box: MuJoCo clamps ctrl, the control cost does not. Falls fast.
        "large": rng.uniform(-5.0, 5.0, size=(steps, nu)),
        "max": np.ones((steps, nu)),
    }


def initial_states(env, rng: np.random.Generator) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Gymnasium's own reset states for seeds 0 and 1, one perturbed more strongly, one fast."""
    u = env.unwrapped
    states = {}
    for seed in (0, 1):
        env.reset(seed=seed)
        states[f"reset{seed}"] = (u.data.qpos.copy(), u.data.qvel.copy())
    qpos = u.init_qpos + rng.uniform(-0.05, 0.05, size=u.model.nq)
    qvel = u.init_qvel + rng.uniform(-0.5, 0.5, size=u.model.nv)
    states["perturbed"] = (qpos, qvel)
    # Fast joints (observed velocities beyond the +-10 clip); the pendulum's cart starts near the
    # end of its rail (range [-1, 1]) moving towards it, so that the joint limit's constraint force
    # (observed, clipped to +-10) is exercised.
    qpos = u.init_qpos + rng.uniform(-0.05, 0.05, size=u.model.nq)
    qvel = u.init_qvel + rng.uniform(-15.0, 15.0, size=u.model.nv)
    if env_id_of(env) == "InvertedDoublePendulum-v5":
        qpos[0], qvel[0] = 0.95, 3.0
    states["fast"] = (qpos, qvel)
    return states


def env_id_of(env) -> str:
    return env.spec.id


def rollout(env, qpos: np.ndarray, qvel: np.ndarray, actions: np.ndarray):
    u = env.unwrapped
    env.reset(seed=0)
    mujoco.mj_resetData(u.model, u.data)
    u.set_state(qpos, qvel)
    obs = [u._get_obs().copy()]
    rew, term, xvel = [], [], []
    for a in actions:
        o, r, terminated, _truncated, info = u.step(a.copy())
        obs.append(np.asarray(o, dtype=np.float64).copy())
        rew.append(float(r))
        term.append(bool(terminated))
        if "x_velocity" in info:
            xvel.append(float(info["x_velocity"]))
        if terminated:
            break
    xvel = np.array(xvel, dtype=np.float64) if xvel else None
    return np.array(obs), np.array(rew, dtype=np.float64), np.array(term, dtype=bool), xvel


def main() -> None:
    here = os.path.dirname(os.path.abspath(__file__))
    default_out = os.path.join(here, "..", "..", "crates", "defender-mujoco", "tests", "data")
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=default_out, help="output folder (default: %(default)s)")
    parser.add_argument(
        "--steps", type=int, default=None, help="actions per case (default: 200; 100 for HalfCheetah-v4)"
    )
    parser.add_argument("--tasks", nargs="+", choices=list(TASKS), default=list(TASKS), help="default: all")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    for env_id in args.tasks:
        stem = TASKS[env_id]
        env = gym.make(env_id)
        nu = env.unwrapped.model.nu
        rng = np.random.default_rng(20240607)
        states = initial_states(env, rng)
        # HalfCheetah never terminates, so each of its cases runs every step: fewer keep the file small.
        steps = args.steps or (100 if env_id == "HalfCheetah-v4" else 200)
        patterns = action_patterns(nu, steps, rng)
        arrays: dict[str, np.ndarray] = {}
        names = []
        i = 0
        for sname, (qpos, qvel) in states.items():
            for pname, actions in patterns.items():
                obs, rew, term, xvel = rollout(env, qpos, qvel, actions)
                # Keep only the actions that were applied (up to and including termination).
                used = actions[: len(rew)]
                arrays.update(
                    {
                        f"case{i}_qpos": qpos,
                        f"case{i}_qvel": qvel,
                        f"case{i}_actions": used,
                        f"case{i}_obs": obs,
                        f"case{i}_rew": rew,
                        f"case{i}_terminated": term,
                    }
                )
                if xvel is not None:
                    arrays[f"case{i}_x_velocity"] = xvel
                names.append(f"{sname}/{pname}")
                vmax = f" max x_velocity {xvel.max():7.3f}" if xvel is not None else ""
                print(f"{env_id:28s} case{i:<2d} {sname:9s}/{pname:7s} steps {len(rew):4d} terminated {bool(term[-1])}{vmax}")
                if env_id == "Hopper-v5" and sname == "reset0" and pname == "uniform":
                    np.save(os.path.join(args.out, "cli_hopper_qpos.npy"), qpos)
                    np.save(os.path.join(args.out, "cli_hopper_qvel.npy"), qvel)
                    np.save(os.path.join(args.out, "cli_hopper_actions.npy"), used)
                    np.savez(os.path.join(args.out, "cli_hopper_expected.npz"), obs=obs, rew=rew, terminated=term)
                i += 1
        arrays["cases"] = np.array(i, dtype=np.int64)
        np.savez_compressed(os.path.join(args.out, f"{stem}.npz"), **arrays)
        env.close()


if __name__ == "__main__":
    main()
