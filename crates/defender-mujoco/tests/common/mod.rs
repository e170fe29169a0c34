//! The golden rollouts of `tools/golden/gym_record.py` (Gymnasium 1.4.0 on MuJoCo 3.17.0), read for the
//! parity and cost tests.

#![allow(clippy::unwrap_used, dead_code)] // test helpers; each test file uses a part

use std::path::Path;

/// One recorded case: a start state, the actions applied, and what Gymnasium returned.
pub struct Case {
    pub qpos: Vec<f64>,
    pub qvel: Vec<f64>,
    pub actions: Vec<f64>,
    pub obs: Vec<f64>,
    pub obs_shape: Vec<u64>,
    pub rew: Vec<f64>,
    pub terminated: Vec<bool>,
    /// `info["x_velocity"]` of each step; empty for a task that does not report it (the pendulum).
    pub x_velocity: Vec<f64>,
}

fn array<T: npyz::Deserialize>(
    npz: &mut npyz::npz::NpzArchive<std::io::BufReader<std::fs::File>>,
    name: &str,
) -> Option<(Vec<T>, Vec<u64>)> {
    let arr = npz.by_name(name).unwrap()?;
    let shape = arr.shape().to_vec();
    Some((arr.into_vec().unwrap(), shape))
}

fn required<T: npyz::Deserialize>(
    npz: &mut npyz::npz::NpzArchive<std::io::BufReader<std::fs::File>>,
    file: &str,
    name: &str,
) -> (Vec<T>, Vec<u64>) {
    array(npz, name).unwrap_or_else(|| panic!("{file}: missing array {name}"))
}

/// The cases of `tests/data/<file>`.
pub fn load(file: &str) -> Vec<Case> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(file);
    let mut npz = npyz::npz::NpzArchive::open(&path).unwrap();
    let (cases, _) = required::<i64>(&mut npz, file, "cases");
    (0..cases[0])
        .map(|i| {
            let (obs, obs_shape) = required(&mut npz, file, &format!("case{i}_obs"));
            Case {
                qpos: required(&mut npz, file, &format!("case{i}_qpos")).0,
                qvel: required(&mut npz, file, &format!("case{i}_qvel")).0,
                actions: required(&mut npz, file, &format!("case{i}_actions")).0,
                obs,
                obs_shape,
                rew: required(&mut npz, file, &format!("case{i}_rew")).0,
                terminated: required(&mut npz, file, &format!("case{i}_terminated")).0,
                x_velocity: array(&mut npz, &format!("case{i}_x_velocity")).map(|a| a.0).unwrap_or_default(),
            }
        })
        .collect()
}
