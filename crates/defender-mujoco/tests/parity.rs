//! Parity with Gymnasium 1.4.0: replays the rollouts recorded by `tools/gym_record.py`
//! (Gymnasium's own environments, same MuJoCo 3.17.0) and compares every observation, reward
//! and termination flag, through termination, within 1e-6.
//!
//! Regenerate the data: `.deps/tools-venv/bin/python tools/gym_record.py`.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

use std::path::Path;

use defender_mujoco::{MujocoEnv, Task, replay};

const TOL: f64 = 1e-6;

struct Case {
    qpos: Vec<f64>,
    qvel: Vec<f64>,
    actions: Vec<f64>,
    obs: Vec<f64>,
    obs_shape: Vec<u64>,
    rew: Vec<f64>,
    terminated: Vec<bool>,
}

fn array<T: npyz::Deserialize>(
    npz: &mut npyz::npz::NpzArchive<std::io::BufReader<std::fs::File>>,
    name: &str,
) -> (Vec<T>, Vec<u64>) {
    let arr = npz.by_name(name).unwrap().unwrap_or_else(|| panic!("missing array {name}"));
    let shape = arr.shape().to_vec();
    (arr.into_vec().unwrap(), shape)
}

fn load(file: &str) -> Vec<Case> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(file);
    let mut npz = npyz::npz::NpzArchive::open(&path).unwrap();
    let (cases, _) = array::<i64>(&mut npz, "cases");
    (0..cases[0])
        .map(|i| {
            let (obs, obs_shape) = array(&mut npz, &format!("case{i}_obs"));
            Case {
                qpos: array(&mut npz, &format!("case{i}_qpos")).0,
                qvel: array(&mut npz, &format!("case{i}_qvel")).0,
                actions: array(&mut npz, &format!("case{i}_actions")).0,
                obs,
                obs_shape,
                rew: array(&mut npz, &format!("case{i}_rew")).0,
                terminated: array(&mut npz, &format!("case{i}_terminated")).0,
            }
        })
        .collect()
}

/// Replays every recorded case and returns how many ended terminated.
fn check(task: Task, file: &str) -> usize {
    let cases = load(file);
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
