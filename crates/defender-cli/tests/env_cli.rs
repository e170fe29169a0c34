//! End-to-end: the built `defender` binary's `env list` and `env replay`, on a Gymnasium
//! recording made by `tools/golden/gym_record.py` (arrays written by numpy's `np.save`).

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

use std::path::{Path, PathBuf};
use std::process::Command;

use npyz::WriterBuilder;

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
fn list_shows_every_task_with_its_cost() {
    let out = defender(&["env", "list"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split_whitespace().collect()).collect();
    assert_eq!(rows[0], ["id", "obs_dim", "act_dim", "horizon", "cost", "threshold"], "{text}");
    for want in [
        &["Walker2d-v5", "17", "6", "1000", "crash", "-"][..],
        &["InvertedDoublePendulum-v5", "9", "1", "1000", "crash", "-"],
        &["HalfCheetah-v4", "17", "6", "1000", "none", "-"],
        &["SafetyHopperVelocity-v1", "11", "3", "1000", "velocity", ">", "0.7402", "0.7402"],
        &["SafetyWalker2dVelocity-v1", "17", "6", "1000", "velocity", ">", "2.3415", "2.3415"],
        &["SafetyHalfCheetahVelocity-v1", "17", "6", "1000", "velocity", ">", "3.2096", "3.2096"],
    ] {
        assert!(rows.iter().any(|r| r == want), "no row {want:?} in\n{text}");
    }
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
    // Hopper-v5's cost is the crash: 1 on the falling step only.
    let (cost, _) = read::<f64>(&out, "cost");
    assert_eq!(cost, term.iter().map(|&t| if t { 1.0 } else { 0.0 }).collect::<Vec<_>>());
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

/// Writes a float64 array of shape `shape` as numpy's `np.save` would.
fn save(path: &Path, shape: &[u64], values: &[f64]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut writer =
        npyz::WriteOptions::<f64>::new().default_dtype().shape(shape).writer(file).begin_nd().unwrap();
    writer.extend(values.iter().copied()).unwrap();
    writer.finish().unwrap();
}

/// The arrays of `case{i}_{name}` in a golden `.npz` of defender-mujoco's tests.
fn golden(file: &str, case: usize, name: &str) -> (Vec<f64>, Vec<u64>) {
    let npz = data(file);
    // read_array takes a static name; a few leaked bytes in a test are fine.
    let name: &'static str = Box::leak(format!("case{case}_{name}").into_boxed_str());
    let (shape, values) = defender::npz::read_array(&npz, name).unwrap().unwrap();
    let values = f64::from_values(values).unwrap();
    (values, shape.into_iter().map(|d| d as u64).collect())
}

#[test]
fn replay_writes_the_velocity_cost_and_no_cost_for_a_plain_v4_task() {
    let dir = scratch("velocity");
    // Case 4 of the Hopper-v4 recording (reset0, maximal torque) speeds up past 0.7402 m/s and falls.
    let (qpos, qvel, actions) = (
        golden("hopper_v4.npz", 4, "qpos"),
        golden("hopper_v4.npz", 4, "qvel"),
        golden("hopper_v4.npz", 4, "actions"),
    );
    let (x_velocity, _) = golden("hopper_v4.npz", 4, "x_velocity");
    let paths = [dir.join("q.npy"), dir.join("v.npy"), dir.join("a.npy")];
    for (path, (values, shape)) in paths.iter().zip([&qpos, &qvel, &actions]) {
        save(path, shape, values);
    }
    let run = |env: &str, out: &Path| {
        let mut args = vec!["env", "replay", "--env", env, "--out", out.to_str().unwrap()];
        for (flag, path) in ["--qpos", "--qvel", "--actions"].iter().zip(&paths) {
            args.extend([*flag, path.to_str().unwrap()]);
        }
        defender(&args)
    };
    let safety = dir.join("safety.npz");
    let result = run("SafetyHopperVelocity-v1", &safety);
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    let (cost, shape) = read::<f64>(&safety, "cost");
    let want: Vec<f64> = x_velocity.iter().map(|&v| if v > 0.7402 { 1.0 } else { 0.0 }).collect();
    assert_eq!((cost.clone(), shape), (want.clone(), vec![want.len() as u64]));
    assert!(cost.contains(&1.0) && cost.contains(&0.0), "both sides of the threshold: {cost:?}");
    let summary = String::from_utf8(result.stdout).unwrap();
    assert!(summary.contains(&format!("cost {}", cost.iter().sum::<f64>())), "{summary}");

    // The plain v4 task: same rollout, no cost array (the output it would always have had).
    let plain = dir.join("plain.npz");
    assert!(run("Hopper-v4", &plain).status.success());
    assert_eq!(read::<f64>(&plain, "rew"), read::<f64>(&safety, "rew"));
    assert!(defender::npz::read_array(&plain, "cost").unwrap().is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}
