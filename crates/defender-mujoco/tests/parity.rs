//! Parity with Gymnasium 1.4.0: replays the rollouts recorded by `tools/golden/gym_record.py`
//! (Gymnasium's own environments, same MuJoCo 3.17.0) and compares every observation, reward
//! and termination flag, through termination, within 1e-6. Safety-Gymnasium's velocity tasks
//! are their v4 base with a cost: they replay the v4 recordings (their costs: velocity_cost.rs).
//!
//! Regenerate the data: `.deps/tools-venv/bin/python tools/golden/gym_record.py`.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

mod common;

use defender_mujoco::{MujocoEnv, Task, replay};

const TOL: f64 = 1e-6;

/// Replays every recorded case and returns how many ended terminated.
fn check(task: Task, file: &str) -> usize {
    let cases = common::load(file);
    assert!(cases.len() >= 10, "{file}: expected at least 10 cases");
    let mut env = MujocoEnv::new(task).unwrap();
    let mut terminated_cases = 0;
    for (i, case) in cases.iter().enumerate() {
        let got = replay(&mut env, &case.qpos, &case.qvel, &case.actions).unwrap();
        assert_eq!(got.steps(), case.rew.len(), "{file} case {i}: number of steps");
        assert_eq!(case.obs_shape, [case.rew.len() as u64 + 1, got.obs_dim as u64], "{file} case {i}");
        assert!(!got.unstable, "{file} case {i}: unexpected instability");
        for (k, (g, w)) in got.obs.iter().zip(&case.obs).enumerate() {
            assert!(
                (g - w).abs() <= TOL,
                "{file} case {i}: obs[{}][{}] = {g}, Gymnasium {w}",
                k / got.obs_dim,
                k % got.obs_dim
            );
        }
        for (t, (g, w)) in got.rewards.iter().zip(&case.rew).enumerate() {
            assert!((g - w).abs() <= TOL, "{file} case {i}: reward[{t}] = {g}, Gymnasium {w}");
        }
        assert_eq!(got.terminated, case.terminated, "{file} case {i}: terminated flags");
        terminated_cases += usize::from(case.terminated.last() == Some(&true));
    }
    terminated_cases
}

#[test]
fn hopper_matches_gymnasium() {
    assert!(check(Task::Hopper, "hopper_v5.npz") >= 5, "the data must include falls");
}

#[test]
fn walker2d_matches_gymnasium() {
    assert!(check(Task::Walker2d, "walker2d_v5.npz") >= 5, "the data must include falls");
}

#[test]
fn inverted_double_pendulum_matches_gymnasium() {
    assert!(check(Task::InvertedDoublePendulum, "inverted_double_pendulum_v5.npz") >= 5);
}

#[test]
fn hopper_v4_and_its_velocity_task_match_gymnasium() {
    // Falls matter here: v4 pays the healthy reward on the falling step, v5 does not.
    assert!(check(Task::HopperV4, "hopper_v4.npz") >= 5, "the data must include falls");
    check(Task::SafetyHopperVelocity, "hopper_v4.npz");
}

#[test]
fn walker2d_v4_and_its_velocity_task_match_gymnasium() {
    assert!(check(Task::Walker2dV4, "walker2d_v4.npz") >= 5, "the data must include falls");
    check(Task::SafetyWalker2dVelocity, "walker2d_v4.npz");
}

#[test]
fn half_cheetah_v4_and_its_velocity_task_match_gymnasium() {
    assert_eq!(check(Task::HalfCheetahV4, "half_cheetah_v4.npz"), 0, "HalfCheetah never terminates");
    check(Task::SafetyHalfCheetahVelocity, "half_cheetah_v4.npz");
}
