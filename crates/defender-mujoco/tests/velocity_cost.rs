//! Safety-Gymnasium's velocity cost on recorded rollouts: every step of the v4 recordings
//! (`tools/golden/gym_record.py`, Gymnasium 1.4.0's `info["x_velocity"]`) replayed on the velocity task
//! costs exactly `float(x_velocity > threshold)`, as safety-gymnasium 1.0.0's
//! `safety_*_velocity_v0.py` computes it; a fall costs nothing by itself; the v4 bases cost 0;
//! a step on which MuJoCo becomes unstable costs 1, whatever its velocity.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

mod common;

use defender_mujoco::{Cost, MujocoEnv, Task, replay};
use defender_rl::Env;

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

/// A step on which MuJoCo becomes unstable ends the episode and costs 1 on a velocity task
/// (docs/SPEC.md section 13, docs/peers.md), as on a crash task, and 0 on the cost-free v4 bases.
/// The velocity used here is backwards, so the velocity rule alone would call the step free: the
/// cost comes from the instability.
#[test]
fn an_unstable_step_costs_one_on_a_velocity_task() {
    let cases = [
        (Task::SafetyHopperVelocity, 1.0),
        (Task::SafetyWalker2dVelocity, 1.0),
        (Task::SafetyHalfCheetahVelocity, 1.0),
        (Task::Hopper, 1.0),
        (Task::HopperV4, 0.0),
        (Task::Walker2dV4, 0.0),
        (Task::HalfCheetahV4, 0.0),
    ];
    for (task, want) in cases {
        let mut env = MujocoEnv::new(task).unwrap();
        env.reset(Some(0)).unwrap();
        let qpos = env.qpos().to_vec();
        let mut qvel = vec![0.0; env.qvel().len()];
        // The root's x-velocity, far past MuJoCo's limit (1e10): it warns and resets its data.
        qvel[0] = -1e12;
        env.set_state(&qpos, &qvel).unwrap();
        let step = env.step(&vec![0.0; env.action_space().dim()]).unwrap();
        assert!(step.info.unstable && step.terminated && !step.truncated, "{}: {step:?}", task.id());
        assert_eq!(step.cost, want, "{}: the cost of an unstable step", task.id());
    }

    // The other way a step becomes unstable, a non-finite reward (the control cost of a 1e200
    // action overflows), through replay: the calm first step is free, the unstable one costs 1.
    let mut env = MujocoEnv::new(Task::SafetyHopperVelocity).unwrap();
    let qpos = [0.0, 1.25, 0.0, 0.0, 0.0, 0.0];
    let got = replay(&mut env, &qpos, &[0.0; 6], &[0.0, 0.0, 0.0, 1e200, 0.0, 0.0]).unwrap();
    assert!(got.unstable && got.terminated == [false, true], "{got:?}");
    assert_eq!(got.costs, [0.0, 1.0]);
}
