//! End-to-end: the built `defender` binary's `env list` and `env replay`, on a Gymnasium
//! recording made by `tools/gym_record.py` (arrays written by numpy's `np.save`).

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../defender-mujoco/tests/data").join(name)
}

/// A fresh empty folder under the system temp dir, unique to this test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("defender-env-cli-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn defender(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_defender")).args(args).output().unwrap()
}

/// An element type of an `.npz` array as `defender::npz` reads it.
trait Element: Sized {
    fn from_values(values: defender::npz::Values) -> Option<Vec<Self>>;
}

impl Element for f64 {
    fn from_values(values: defender::npz::Values) -> Option<Vec<Self>> {
        match values {
            defender::npz::Values::F64(v) => Some(v),
            _ => None,
        }
    }
}

impl Element for bool {
    fn from_values(values: defender::npz::Values) -> Option<Vec<Self>> {
        match values {
            defender::npz::Values::Bool(v) => Some(v),
            _ => None,
        }
    }
}

fn read<T: Element>(npz: &Path, name: &'static str) -> (Vec<T>, Vec<u64>) {
    let (shape, values) = defender::npz::read_array(npz, name)
        .unwrap()
        .unwrap_or_else(|| panic!("{}: no {name}", npz.display()));
    let values =
        T::from_values(values).unwrap_or_else(|| panic!("{}: {name} has another dtype", npz.display()));
    (values, shape.into_iter().map(|d| d as u64).collect())
}

#[test]
fn list_shows_the_three_tasks() {
    let out = defender(&["env", "list"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for id in ["Hopper-v5", "Walker2d-v5", "InvertedDoublePendulum-v5"] {
        assert!(text.contains(id), "{text}");
    }
    assert!(
        text.lines().any(|l| l.split_whitespace().collect::<Vec<_>>() == ["Walker2d-v5", "17", "6", "1000"])
    );
}

#[test]
fn replay_reproduces_the_gymnasium_recording() {
    let dir = scratch("replay");
    let out = dir.join("out.npz");
    let (q, v, a) =
        (data("cli_hopper_qpos.npy"), data("cli_hopper_qvel.npy"), data("cli_hopper_actions.npy"));
    let args = [
        "env",
        "replay",
        "--env",
        "Hopper-v5",
        "--qpos",
        q.to_str().unwrap(),
        "--qvel",
        v.to_str().unwrap(),
        "--actions",
        a.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let run = defender(&args);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let expected = data("cli_hopper_expected.npz");
    let (obs, obs_shape) = read::<f64>(&out, "obs");
    let (want_obs, want_shape) = read::<f64>(&expected, "obs");
    assert_eq!(obs_shape, want_shape);
    assert!(obs.iter().zip(&want_obs).all(|(a, b)| (a - b).abs() <= 1e-6));
    let (rew, rew_shape) = read::<f64>(&out, "rew");
    let (want_rew, _) = read::<f64>(&expected, "rew");
    assert_eq!(rew_shape, [want_rew.len() as u64]);
    assert!(rew.iter().zip(&want_rew).all(|(a, b)| (a - b).abs() <= 1e-6));
    let (term, _) = read::<bool>(&out, "terminated");
    let (want_term, _) = read::<bool>(&expected, "terminated");
    assert_eq!(term, want_term);
    assert_eq!(term.last(), Some(&true), "the recorded case ends in a fall");
    // Only OUT.npz is left in the folder (the temporary file was renamed).
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, ["out.npz"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn replay_names_the_bad_file_and_what_was_expected() {
    let dir = scratch("bad");
    let out = dir.join("out.npz");
    let run = |qpos: &Path, actions: &Path| {
        defender(&[
            "env",
            "replay",
            "--env",
            "Hopper-v5",
            "--qpos",
            qpos.to_str().unwrap(),
            "--qvel",
            data("cli_hopper_qvel.npy").to_str().unwrap(),
            "--actions",
            actions.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    // Walker2d-sized actions ([T, 6]) given to Hopper: wrong shape.
    let wrong = dir.join("actions6.npy");
    npyz::to_file_1d(&wrong, vec![0.0f64; 6]).unwrap();
    let result = run(&data("cli_hopper_qpos.npy"), &wrong);
    assert!(!result.status.success());
    let err = String::from_utf8(result.stderr).unwrap();
    assert!(err.contains("actions6.npy") && err.contains("shape [6]") && err.contains("[T, 3]"), "{err}");

    // qpos stored as float32.
    let f32_qpos = dir.join("qpos32.npy");
    npyz::to_file_1d(&f32_qpos, vec![0.0f32; 6]).unwrap();
    let err = String::from_utf8(run(&f32_qpos, &data("cli_hopper_actions.npy")).stderr).unwrap();
    assert!(err.contains("qpos32.npy") && err.contains("<f4") && err.contains("float64"), "{err}");

    // Not an .npy at all, and a missing file.
    let text = dir.join("notes.npy");
    std::fs::write(&text, "hello").unwrap();
    let err = String::from_utf8(run(&text, &data("cli_hopper_actions.npy")).stderr).unwrap();
    assert!(err.contains("notes.npy") && err.contains("not a readable .npy"), "{err}");
    let err =
        String::from_utf8(run(&dir.join("missing.npy"), &data("cli_hopper_actions.npy")).stderr).unwrap();
    assert!(err.contains("missing.npy") && err.contains("cannot open"), "{err}");

    // Unknown task id.
    let result = defender(&[
        "env",
        "replay",
        "--env",
        "Ant-v5",
        "--qpos",
        "q",
        "--qvel",
        "v",
        "--actions",
        "a",
        "--out",
        "o",
    ]);
    let err = String::from_utf8(result.stderr).unwrap();
    assert!(!result.status.success() && err.contains("Ant-v5") && err.contains("Hopper-v5"), "{err}");

    assert!(!out.exists(), "no output on error");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn replay_help_has_an_example() {
    let out = defender(&["env", "replay", "--help"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("Example") && text.contains("defender env replay --env Hopper-v5"), "{text}");
}
