//! Safety-Gymnasium's velocity cost on recorded rollouts: every step of the v4 recordings
//! (`tools/gym_record.py`, Gymnasium 1.4.0's `info["x_velocity"]`) replayed on the velocity task
//! costs exactly `float(x_velocity > threshold)`, as safety-gymnasium 1.0.0's
//! `safety_*_velocity_v0.py` computes it; a fall costs nothing by itself; the v4 bases cost 0.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

mod common;

use defender_mujoco::{Cost, MujocoEnv, Task, replay};

/// Replays `file` on `task` and checks its costs; returns (costly steps, free steps, falls that
/// cost nothing).
fn check(task: Task, file: &str, threshold: f64) -> (usize, usize, usize) {
    assert_eq!(task.cost(), Cost::Velocity { threshold }, "{}: the v1 threshold", task.id());
    let mut env = MujocoEnv::new(task).unwrap();
    let (mut costly, mut free, mut free_falls) = (0, 0, 0);
    for (i, case) in common::load(file).iter().enumerate() {
        assert_eq!(case.x_velocity.len(), case.rew.len(), "{file} case {i}: x_velocity per step");
        let got = replay(&mut env, &case.qpos, &case.qvel, &case.actions).unwrap();
        for (t, (&cost, &v)) in got.costs.iter().zip(&case.x_velocity).enumerate() {
            // Gymnasium's velocity and ours agree to ~1e-12; a step that close to the threshold
            // could go either way and would prove nothing.
            assert!((v - threshold).abs() > 1e-9, "{file} case {i} step {t}: velocity {v} at the threshold");
            let want = if v > threshold { 1.0 } else { 0.0 };
            assert_eq!(cost, want, "{file} case {i} step {t}: x_velocity {v}, threshold {threshold}");
            if cost == 1.0 {
                costly += 1
            } else {
                free += 1
            }
            if got.terminated[t] && cost == 0.0 {
                free_falls += 1;
            }
        }
    }
    (costly, free, free_falls)
}

/// The v4 base of a velocity task costs nothing on the same steps.
fn base_costs_nothing(base: Task, file: &str) {
    let mut env = MujocoEnv::new(base).unwrap();
    for case in common::load(file) {
        let got = replay(&mut env, &case.qpos, &case.qvel, &case.actions).unwrap();
        assert!(got.costs.iter().all(|&c| c == 0.0), "{}: a plain v4 task has no cost", base.id());
    }
}

#[test]
fn hopper_velocity_cost_follows_safety_gymnasium() {
    let (costly, free, free_falls) = check(Task::SafetyHopperVelocity, "hopper_v4.npz", 0.7402);
    assert!(costly >= 10 && free >= 10, "both sides of the threshold: {costly} costly, {free} free");
    assert!(free_falls >= 5, "a fall is not a cost on a velocity task");
    base_costs_nothing(Task::HopperV4, "hopper_v4.npz");
}

#[test]
fn walker2d_velocity_cost_follows_safety_gymnasium() {
    let (costly, free, free_falls) = check(Task::SafetyWalker2dVelocity, "walker2d_v4.npz", 2.3415);
    assert!(costly >= 10 && free >= 10, "both sides of the threshold: {costly} costly, {free} free");
    assert!(free_falls >= 5, "a fall is not a cost on a velocity task");
    base_costs_nothing(Task::Walker2dV4, "walker2d_v4.npz");
}

#[test]
fn half_cheetah_velocity_cost_follows_safety_gymnasium() {
    let (costly, free, _) = check(Task::SafetyHalfCheetahVelocity, "half_cheetah_v4.npz", 3.2096);
    assert!(costly >= 10 && free >= 10, "both sides of the threshold: {costly} costly, {free} free");
    base_costs_nothing(Task::HalfCheetahV4, "half_cheetah_v4.npz");
}

#[test]
fn v5_tasks_cost_their_crash_step_only() {
    let mut env = MujocoEnv::new(Task::Hopper).unwrap();
    for case in common::load("hopper_v5.npz") {
        let got = replay(&mut env, &case.qpos, &case.qvel, &case.actions).unwrap();
        let crash: Vec<f64> = got.terminated.iter().map(|&t| if t { 1.0 } else { 0.0 }).collect();
        assert_eq!(got.costs, crash);
    }
}
