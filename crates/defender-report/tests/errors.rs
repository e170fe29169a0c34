//! Broken run directories: each error names the file and what is wrong. And finding run
//! directories under parent folders.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use std::path::Path;

use common::{A, RunSpec};
use defender_report::{ReportError, Run, find_run_dirs, load_runs};

fn broken(edit: impl FnOnce(&Path)) -> (tempfile::TempDir, std::path::PathBuf, ReportError) {
    let root = tempfile::tempdir().unwrap();
    let dir = RunSpec::new("sac", 0, A).outcomes(4, 1, 1).write(root.path());
    Run::load(&dir).unwrap();
    edit(&dir);
    let err = load_runs(&[root.path()]).unwrap_err();
    (root, dir, err)
}

fn replace(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "{from:?} not in {text}");
    std::fs::write(path, text.replacen(from, to, 1)).unwrap();
}

#[test]
fn a_missing_file_is_named() {
    let (_root, dir, err) = broken(|d| std::fs::remove_file(d.join("metrics.csv")).unwrap());
    assert!(matches!(err, ReportError::MissingFile { .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        format!(
            "{}: missing; a run directory holds config.toml, metrics.csv, eval.csv and summary.json \
             (docs/run-directory.md)",
            dir.join("metrics.csv").display()
        )
    );
}

#[test]
fn a_bad_csv_header_names_the_missing_column() {
    let (_root, dir, err) = broken(|d| replace(&d.join("metrics.csv"), "total_steps,", "steps,"));
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}: bad header", dir.join("metrics.csv").display())), "{msg}");
    assert!(msg.contains("missing column \"total_steps\""), "{msg}");
    let (_root, dir, err) = broken(|d| std::fs::write(d.join("eval.csv"), "").unwrap());
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}: bad header \"\"", dir.join("eval.csv").display())), "{msg}");
}

#[test]
fn bad_rows_name_the_line_and_column() {
    let (_root, dir, err) = broken(|d| replace(&d.join("metrics.csv"), "filtered", "exploded"));
    assert_eq!(
        err.to_string(),
        format!(
            "{}:3: column outcome: \"exploded\" is not one of crashed, filtered, truncated",
            dir.join("metrics.csv").display()
        )
    );
    let (_root, dir, err) = broken(|d| replace(&d.join("eval.csv"), "\n200,", "\n2e2x,"));
    assert_eq!(
        err.to_string(),
        format!("{}:3: column total_steps: cannot read \"2e2x\"", dir.join("eval.csv").display())
    );
    let (_root, _dir, err) = broken(|d| replace(&d.join("metrics.csv"), "\n1,", "\n7,"));
    assert!(err.to_string().ends_with(":3: episode 7 out of order: expected 1"), "{err}");
    let (_root, _dir, err) =
        broken(|d| replace(&d.join("metrics.csv"), ",100,crashed", ",100,crashed,extra"));
    assert!(err.to_string().ends_with(":2: 7 fields, the header has 6"), "{err}");
}

#[test]
fn bad_json_and_toml_are_named() {
    let (_root, dir, err) =
        broken(|d| replace(&d.join("summary.json"), "\"complete\": true\n}", "\"complete\": true"));
    assert!(matches!(err, ReportError::Json { .. }), "{err:?}");
    assert!(err.to_string().starts_with(&format!("{}: EOF", dir.join("summary.json").display())), "{err}");
    let (_root, dir, err) = broken(|d| replace(&d.join("summary.json"), "\"acc_reward\": 100.0,", ""));
    assert!(
        err.to_string()
            .starts_with(&format!("{}: acc_reward is missing or null", dir.join("summary.json").display())),
        "{err}"
    );
    let (_root, _dir, err) =
        broken(|d| replace(&d.join("summary.json"), "\"acc_reward\": 100.0", "\"acc_reward\": null"));
    assert!(matches!(err, ReportError::Invalid { .. }), "{err:?}");
    assert!(err.to_string().contains("acc_reward is missing or null"), "{err}");
    let (_root, _dir, err) =
        broken(|d| replace(&d.join("summary.json"), "\"complete\": true", "\"complete\": \"yes\""));
    assert!(err.to_string().contains("\"complete\" must be true or false"), "{err}");
    let (_root, dir, err) = broken(|d| replace(&d.join("config.toml"), "seed = 0", "seed = zero"));
    assert!(matches!(err, ReportError::Toml { .. }), "{err:?}");
    assert!(err.to_string().starts_with(&dir.join("config.toml").display().to_string()), "{err}");
    let (_root, _dir, err) =
        broken(|d| replace(&d.join("config.toml"), "mode = \"state\"", "mode = \"pixels\""));
    assert!(err.to_string().contains("[defender] mode = \"pixels\": expected \"state\" or \"state-action\""));
    let (_root, _dir, err) =
        broken(|d| replace(&d.join("config.toml"), "total_steps = 400", "total_steps = 0"));
    assert!(err.to_string().contains("exactly one of total_steps (0) and total_episodes (0)"), "{err}");
}

#[test]
fn files_that_contradict_each_other_are_errors() {
    let summary = |d: &Path| d.join("summary.json");
    let (_root, dir, err) = broken(|d| replace(&summary(d), "\"crash_pct\": 25.0", "\"crash_pct\": 30.0"));
    assert_eq!(
        err.to_string(),
        format!(
            "{}: crash_pct = 30 but metrics.csv has 1 crashed of 4 episodes (25.000%)",
            summary(&dir).display()
        )
    );
    // Rounded to 0.1 is fine.
    let root = tempfile::tempdir().unwrap();
    let dir = RunSpec::new("sac", 0, None).outcomes(3, 1, 0).write(root.path());
    replace(&summary(&dir), "33.333333333333336", "33.3");
    Run::load(&dir).unwrap();

    let (_root, _dir, err) = broken(|d| replace(&summary(d), "\"episodes\": 4", "\"episodes\": 5"));
    assert!(err.to_string().ends_with("episodes = 5 but metrics.csv has 4 episodes"), "{err}");
    let (_root, _dir, err) =
        broken(|d| replace(&summary(d), "\"acc_reward\": 100.0", "\"acc_reward\": 99.0"));
    assert!(
        err.to_string().ends_with("acc_reward = 99 but the last row of eval.csv has mean_return 100"),
        "{err}"
    );
    let (_root, _dir, err) = broken(|d| replace(&summary(d), "\"seed\": 0", "\"seed\": 3"));
    assert!(
        err.to_string().contains("env/algo/seed Hopper-v5/sac/3 disagree with config.toml's Hopper-v5/sac/0")
    );
    let (_root, _dir, err) =
        broken(|d| replace(&summary(d), "\"mode\": \"state\"", "\"mode\": \"state-action\""));
    assert!(err.to_string().contains("disagree with config.toml's [defender] table"), "{err}");
    let (_root, dir, err) = broken(|d| {
        std::fs::write(d.join("eval.csv"), "total_steps,mean_return,std_return,mean_length,episodes\n")
            .unwrap()
    });
    assert_eq!(
        err.to_string(),
        format!(
            "{}: no evaluation row; a complete run ends with its final evaluation",
            dir.join("eval.csv").display()
        )
    );
}

#[test]
fn the_same_run_twice_is_an_error_but_the_same_directory_twice_is_not() {
    let root = tempfile::tempdir().unwrap();
    let a = RunSpec::new("sac", 0, None).write(root.path());
    // One directory through two arguments counts once.
    assert_eq!(load_runs(&[root.path(), a.as_path()]).unwrap().runs.len(), 1);
    let copy = root.path().join("copy");
    std::fs::create_dir(&copy).unwrap();
    for f in ["config.toml", "metrics.csv", "eval.csv", "summary.json"] {
        std::fs::copy(a.join(f), copy.join(f)).unwrap();
    }
    let err = load_runs(&[root.path()]).unwrap_err();
    assert!(matches!(err, ReportError::Duplicate { .. }), "{err:?}");
    assert!(err.to_string().contains("are the same run (Hopper-v5 sac 400 steps bare seed 0)"), "{err}");
}

#[test]
fn run_directories_are_found_one_or_two_levels_down() {
    let root = tempfile::tempdir().unwrap();
    let direct = RunSpec::new("sac", 0, None).write(root.path());
    let nested = RunSpec::new("sac", 1, None).write(&root.path().join("hopper"));
    let deep = RunSpec::new("sac", 2, None).write(&root.path().join("x/y"));
    // Not a run directory (no summary.json): ignored.
    std::fs::create_dir_all(root.path().join("notes")).unwrap();
    let found = find_run_dirs(&[root.path()]).unwrap();
    // Sorted by path components: `hopper` before `hopper-v5_...`.
    assert_eq!(found, vec![nested.clone(), direct.clone()], "three levels down is not searched");
    assert_eq!(find_run_dirs(&[root.path().join("x")]).unwrap(), vec![deep.clone()]);
    assert_eq!(find_run_dirs(&[&direct]).unwrap(), vec![direct]);

    let err = find_run_dirs(&[root.path().join("notes")]).unwrap_err();
    assert!(matches!(err, ReportError::NoRuns { .. }));
    assert!(
        err.to_string().ends_with(
            "notes: no run directory found (looked for summary.json in it and one or two levels below it)"
        ),
        "{err}"
    );
    let err = find_run_dirs(&[root.path().join("nope")]).unwrap_err();
    assert!(err.to_string().ends_with("nope: no such file or directory"), "{err}");
}
