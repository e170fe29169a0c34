"""Parity: DefenderWrapper around Gymnasium's own MuJoCo Hopper-v5 and the Rust DefenderEnv around
defender-mujoco's Hopper-v5 (crates/defender/examples/defender_trace.rs), started from the same
states and fed the same actions, make the same decision at every step, with the same costs (the
filter's DTW costs and the steps' safety costs), the same observations (the dynamics model's
predictions on filtered steps), rewards and outcomes.

Each episode starts as `defender env replay` does: Gymnasium's reset, then MuJoCo's data reset,
then set_state(qpos, qvel). Both sides seed the dynamics model with ChaCha8Rng(seed)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

import gymnasium as gym
import mujoco
import numpy as np
import pytest

from defender_rl import DefenderWrapper

from conftest import HOPPER_DEMOS, ROOT

SEED = 7
STRATEGIES = ["MeanDemoW5/MeanDemoW10", "MinDemoW5/MinDemoW10"]


class ResetToState(gym.Wrapper):
    """Episode k starts from states[k], as `defender_mujoco::replay` / `MujocoEnv::reset_to`."""

    def __init__(self, env, states):
        super().__init__(env)
        self.states = list(states)
        self.next = 0

    def reset(self, *, seed=None, options=None):
        self.env.reset(seed=seed, options=options)
        u = self.env.unwrapped
        qpos, qvel = self.states[self.next]
        self.next += 1
        mujoco.mj_resetData(u.model, u.data)
        u.set_state(qpos, qvel)
        return u._get_obs(), {}


def rust_trace(payload, tmp_path):
    cargo = shutil.which("cargo")
    assert cargo, "cargo is needed to build the Rust side of the parity test"
    subprocess.run(
        [cargo, "build", "--release", "--quiet", "-p", "defender", "--example", "defender_trace"],
        cwd=ROOT,
        check=True,
    )
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    path = tmp_path / "in.json"
    path.write_text(json.dumps(payload))
    out = subprocess.run(
        [os.path.join(target, "release", "examples", "defender_trace"), str(path)],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout)


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_python_wrapper_and_rust_defender_env_agree(strategy, tmp_path):
    probe = gym.make("Hopper-v5")
    rng = np.random.default_rng(11)
    states, episodes = [], []
    for k in range(10):
        probe.reset(seed=k)
        u = probe.unwrapped
        qpos, qvel = u.data.qpos.copy(), u.data.qvel.copy()
        if k % 3 == 2:  # a push: episodes that fall sooner
            qvel = qvel + rng.normal(0, 0.5, size=qvel.shape)
        actions = rng.uniform(-1, 1, size=(150, 3)) * (0.3 if k % 2 == 0 else 1.0)
        states.append((qpos, qvel))
        episodes.append({"qpos": qpos.tolist(), "qvel": qvel.tolist(), "actions": actions.tolist()})
    dynamics = {"batch_size": 64}
    rust = rust_trace(
        {"env": "Hopper-v5", "demos": str(HOPPER_DEMOS), "strategy": strategy, "seed": SEED,
         "dynamics": dynamics, "episodes": episodes},
        tmp_path,
    )

    env = DefenderWrapper(ResetToState(gym.make("Hopper-v5"), states), HOPPER_DEMOS, strategy, seed=SEED, dynamics=dynamics,
                          profile="spec")  # the Rust trace's DefenderConfig: SPEC's filter
    assert env.r_task == rust["r_task"]
    counts = {"filtered": 0, "executed": 0, "filtered_after_training": 0}
    total_cost = 0.0
    for k, (ep, rep) in enumerate(zip(episodes, rust["episodes"])):
        obs, _ = env.reset()
        np.testing.assert_allclose(obs, rep["reset_obs"], rtol=0, atol=1e-9, err_msg=f"episode {k} reset")
        steps = 0
        for t, action in enumerate(ep["actions"]):
            obs, reward, terminated, truncated, info = env.step(np.asarray(action))
            r = rep["steps"][t]
            where = f"episode {k} step {t}"
            assert info["defender_filtered"] == r["filtered"], where
            assert info["defender_safe_cost"] == pytest.approx(r["safe_cost"], rel=1e-6, abs=1e-6), where
            assert info["defender_unsafe_cost"] == pytest.approx(r["unsafe_cost"], rel=1e-6, abs=1e-6), where
            np.testing.assert_allclose(obs, r["obs"], rtol=1e-6, atol=1e-6, err_msg=where)
            assert reward == pytest.approx(r["reward"], rel=1e-6, abs=1e-6), where
            # Gymnasium's Hopper-v5 has no "cost" in its info: the crash rule, as defender-mujoco's.
            assert info["cost"] == r["cost"], where
            total_cost += info["cost"]
            assert (terminated, truncated) == (r["terminated"], r["truncated"]), where
            steps += 1
            if r["filtered"]:
                counts["filtered"] += 1
                if env.dynamics_info["gradient_steps"] > 0:
                    counts["filtered_after_training"] += 1
            else:
                counts["executed"] += 1
            if terminated or truncated:
                assert info["defender_outcome"] == rep["outcome"], where
                break
        assert steps == len(rep["steps"]), f"episode {k}: {steps} steps in Python, {len(rep['steps'])} in Rust"
    assert env.defender_stats == rust["stats"]
    assert total_cost == env.defender_stats["crashed_episodes"], "a crash costs 1, any other step 0"
    # The comparison covered both kinds of steps, and predictions of a trained model.
    assert counts["executed"] > 20 and counts["filtered_after_training"] >= 3, counts
