//! End-to-end: the built `defender` binary's `bench` subcommand. Only the table's shape and the
//! error messages are checked, never a time.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

use std::process::{Command, Output};

fn defender(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_defender")).args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).unwrap()
}

/// The table's header line and the rows below its rule.
fn table(stdout: &str) -> (Vec<String>, Vec<String>) {
    let lines: Vec<&str> = stdout.lines().collect();
    let at =
        lines.iter().position(|l| l.starts_with("figure ")).unwrap_or_else(|| panic!("no header:\n{stdout}"));
    let header = lines[at].split_whitespace().map(str::to_owned).collect();
    assert!(lines[at + 1].starts_with("------"), "no rule under the header:\n{stdout}");
    let rows = lines[at + 2..].iter().take_while(|l| !l.trim().is_empty()).map(|l| (*l).to_owned()).collect();
    (header, rows)
}

#[test]
fn quick_mujoco_prints_a_row_per_task_and_one_target() {
    let out = defender(&["bench", "--quick", "--only", "mujoco"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "stdout:\n{stdout}\nstderr:\n{}", text(&out.stderr));
    // Machine context first.
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("machine:") && l.contains("cores") && l.contains("load average"))
    );
    assert!(stdout.lines().any(|l| l.starts_with("threads:")));
    let (header, rows) = table(&stdout);
    assert_eq!(header, ["figure", "what", "value", "unit", "target", "status", "notes"]);
    assert_eq!(rows.len(), defender_mujoco::registry().len(), "{stdout}");
    let hopper = rows.iter().find(|r| r.contains("Hopper-v5")).unwrap();
    assert!(hopper.starts_with("mujoco "), "{hopper}");
    assert!(hopper.contains("steps/s") && hopper.contains(">= 5000"), "{hopper}");
    assert!(hopper.contains(" met ") || hopper.contains(" NOT MET "), "{hopper}");
    // The value column parses as a positive number.
    for row in &rows {
        let after_what = row.split("random actions").nth(1).unwrap();
        let value: f64 = after_what.split_whitespace().next().unwrap().parse().unwrap();
        assert!(value > 0.0 && value.is_finite(), "{row}");
    }
    // The summary counts the one target.
    assert!(stdout.lines().any(|l| l.starts_with("targets met: ") && l.contains(" of 1")), "{stdout}");
    // Neither the demonstrations nor training are announced for a MuJoCo-only run.
    assert!(!stdout.contains("demos:") && !stdout.contains("training:"), "{stdout}");
}

#[test]
fn unknown_figure_is_a_clear_error() {
    let out = defender(&["bench", "--quick", "--only", "mujoco,warp-drive"]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(stderr.contains("warp-drive"), "{stderr}");
    for name in ["mujoco", "sac", "td3", "overhead", "dynamics"] {
        assert!(stderr.contains(name), "the error should list '{name}': {stderr}");
    }
    // Nothing was measured.
    assert!(!text(&out.stdout).contains("figure "), "{}", text(&out.stdout));
}

#[test]
fn zero_steps_and_threads_are_refused() {
    for (flag, value) in [("--steps", "0"), ("--threads", "0")] {
        let out = defender(&["bench", "--only", "mujoco", flag, value]);
        assert!(!out.status.success());
        let stderr = text(&out.stderr);
        assert!(stderr.contains(flag) && stderr.contains("at least 1"), "{stderr}");
    }
}

#[test]
fn help_lists_the_figures_with_an_example() {
    let out = defender(&["bench", "--help"]);
    assert!(out.status.success());
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("--only") && stdout.contains("--quick") && stdout.contains("Examples:"),
        "{stdout}"
    );
    assert!(stdout.contains("defender bench --only"), "{stdout}");
}
