//! `defender report` end to end: the built binary on run directories written as
//! docs/run-directory.md says.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

#[path = "../../defender-report/tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{A, RunSpec, paper_fixture};

/// A fresh directory under Cargo's per-target scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("report_cli_{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn defender(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_defender")).args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).unwrap()
}

#[test]
fn markdown_on_stdout_from_a_parent_folder() {
    let root = scratch("markdown");
    paper_fixture(&root.join("runs"));
    let out = defender(&["report", root.join("runs").to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let md = text(&out.stdout);
    assert!(md.starts_with("# DEFENDER report\n"), "{md}");
    let row = md.lines().find(|l| l.contains("MeanDemoW5") && l.starts_with("| SAC")).unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
    // SAC A: acc 110, 110, 140; best episodes 30, 31, 32; mean evaluation 5/8 of acc; crash 25,
    // 0, 25 %; never standing; time 150, 150, 100 % (see common/mod.rs and tests/table.rs).
    assert_eq!(
        cells,
        [
            "SAC",
            "MeanDemoW5",
            "MeanDemoW10",
            "120 ± 14.1 [110, 140]",
            "31 ± 0.8 [30, 32]",
            "75 ± 8.8 [69, 88]",
            "16.7 ± 11.8 [0.0, 25.0]",
            // Crashes over the run: 1, 0, 1 of 4 episodes of 100 steps; per 1,000 of the
            // steps that reached the environment.
            "1 ± 0.5 [0, 1]",
            // Filtered (interventions): 1, 2, 1 episodes over the run.
            "1 ± 0.5 [1, 2]",
            "1.67 ± 1.2 [0.00, 2.51]",
            "0 ± 0.0 [0, 0]",
            "133",
            "3"
        ]
    );
    assert!(md.contains("| Acc Reward (final eval) | Best episode (paper's Acc Reward) |"), "{md}");
    assert!(out.stderr.is_empty(), "{}", text(&out.stderr));
}

#[test]
fn latex_and_csv_to_files_and_plots() {
    let root = scratch("files");
    let runs = root.join("runs");
    paper_fixture(&runs);
    let tex = root.join("out/tables.tex"); // out/ does not exist yet: it is made
    let out = defender(&[
        "report",
        runs.to_str().unwrap(),
        "--format",
        "latex",
        "--out",
        tex.to_str().unwrap(),
        "--plots",
        root.join("plots").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stdout.is_empty());
    let latex = std::fs::read_to_string(&tex).unwrap();
    assert!(
        latex.contains("\\toprule")
            && latex.contains(
                "\\multicolumn{2}{l}{SAC} & 200$\\pm$81.6 & 31$\\pm$0.8 & 50$\\pm$20.4 & 2$\\pm$0.8 & - & 100"
            )
    );
    assert!(!root.join("out/tables.tex.tmp").exists());
    let stderr = text(&out.stderr);
    assert!(stderr.contains("wrote 28 plot files to"), "{stderr}");
    for name in [
        "Hopper-v5_sac_windows.png",
        "Hopper-v5_td3_windows.svg",
        "Hopper-v5_sac_return.png",
        "Hopper-v5_td3_crash.svg",
        "Hopper-v5_td3_eval.png",
        "Hopper-v5_sac_tradeoff.png",
    ] {
        let len = std::fs::metadata(root.join("plots").join(name)).unwrap().len();
        assert!(len > 1000, "{name}: {len} bytes");
    }

    let out = defender(&["report", runs.to_str().unwrap(), "--format", "csv"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    assert_eq!(csv.lines().count(), 7, "{csv}");
    assert!(csv.lines().next().unwrap().starts_with("env,algo,budget_steps,"));
    assert!(csv.contains("\nHopper-v5,td3,500,,MinDemoW5/MinDemoW10,MinDemoW5,MinDemoW10,state,50,3,0;1;2,10,0,0,0,100,0,300,0,3,"));
}

#[test]
fn incomplete_runs_warn_and_missing_bare_runs_are_noted() {
    let root = scratch("warn");
    RunSpec::new("sac", 0, A).write(&root);
    let broken = RunSpec::new("sac", 1, A).write(&root);
    std::fs::write(broken.join("summary.json"), "{\"complete\": false}").unwrap();
    let out = defender(&["report", root.to_str().unwrap(), "--format", "csv"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "warning: skipping {}: broken (summary.json says \"complete\": false, no process holds its lock",
            broken.display()
        )),
        "{stderr}"
    );
    assert!(
        stderr
            .contains("note: % Time of Hopper-v5 SAC MeanDemoW5/MeanDemoW10 (state, 400 steps): no bare run")
    );
}

/// Each skipped run directory is listed with its state, in the warnings and in the report
/// written; `--strict` refuses to write a report short of them.
#[test]
fn skipped_runs_are_listed_and_strict_refuses_them() {
    let root = scratch("strict");
    RunSpec::new("sac", 0, None).write(&root);
    let running = RunSpec::new("sac", 1, None).write(&root);
    std::fs::write(running.join("summary.json"), "{\"complete\": false}").unwrap();
    // Held as `defender train` holds it, for the life of this test.
    let _lock = defender_io::DirLock::try_acquire(&running).unwrap();
    let stopped = RunSpec::new("sac", 2, None).write(&root);
    std::fs::remove_file(stopped.join("summary.json")).unwrap();
    std::fs::create_dir_all(stopped.join("checkpoint")).unwrap();

    let md_path = root.join("report.md");
    let out = defender(&["report", root.to_str().unwrap(), "--out", md_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    let pid = std::process::id();
    assert!(
        stderr.contains(&format!(
            "warning: skipping {}: still running (its lock .lock is held by pid {pid})",
            running.display()
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!(
            "warning: skipping {}: stopped (no summary.json; a checkpoint is present",
            stopped.display()
        )),
        "{stderr}"
    );
    let md = std::fs::read_to_string(&md_path).unwrap();
    assert!(md.contains(&format!("- Left out: {}: still running", running.display())), "{md}");
    assert!(md.contains(&format!("- Left out: {}: stopped", stopped.display())), "{md}");
    let seeds = md
        .lines()
        .find(|l| l.starts_with("| SAC"))
        .unwrap()
        .trim_end_matches(" |")
        .rsplit(' ')
        .next()
        .unwrap();
    assert_eq!(seeds, "1", "the row has the one complete seed: {md}");

    std::fs::remove_file(&md_path).unwrap();
    let out = defender(&["report", root.to_str().unwrap(), "--strict", "--out", md_path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    assert!(
        stderr.starts_with("error: --strict: 2 run directories are not complete; nothing written:\n"),
        "{stderr}"
    );
    assert!(stderr.contains(&format!("  {}: still running", running.display())), "{stderr}");
    assert!(stderr.contains(&format!("  {}: stopped", stopped.display())), "{stderr}");
    assert!(!md_path.exists());
    // Complete runs only: --strict changes nothing.
    let out = defender(&["report", root.join("hopper-v5_sac_bare_s0").to_str().unwrap(), "--strict"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", text(&out.stderr));
}

/// The report's horizons (for Standing %) are the task registry's.
#[test]
fn the_report_knows_every_tasks_horizon() {
    for spec in defender_mujoco::TASKS {
        assert_eq!(defender_report::horizon(spec.id), Some(spec.max_episode_steps as u64), "{}", spec.id);
    }
}

/// The velocity tasks' episode cost limit reaches the report from the task registry: their
/// tables get the cost columns and their plots the cost curves; a crash task's do not.
#[test]
fn a_velocity_task_gets_the_cost_measures_from_the_registry() {
    let root = scratch("costs");
    let runs = root.join("runs");
    // Two 100-step episodes costing 30 and 0 (one of two over 25): cost rate 30 / 200.
    for seed in 0..2 {
        RunSpec::new("sac", seed, None)
            .env("SafetyHopperVelocity-v1")
            .outcomes(2, 0, 0)
            .costs(&[30.0, 0.0])
            .eval_costs(&[3.0, 5.0])
            .write(&runs);
    }
    RunSpec::new("sac", 0, None).outcomes(2, 1, 0).write(&runs);
    let plots = root.join("plots");
    let out = defender(&["report", runs.to_str().unwrap(), "--plots", plots.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let md = text(&out.stdout);
    let tables: Vec<&str> = md.split("\n### ").skip(1).collect();
    assert_eq!(tables.len(), 2, "{md}");
    assert!(tables[0].starts_with("Hopper-v5") && !tables[0].contains("Cost rate"), "{md}");
    assert!(tables[1].starts_with("SafetyHopperVelocity-v1"), "{md}");
    let cells = |prefix: &str| -> Vec<String> {
        let line = tables[1].lines().find(|l| l.starts_with(prefix)).unwrap();
        line.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
    };
    let (header, row) = (cells("| Algorithm"), cells("| SAC"));
    let cost_header = ["Cost rate", "Eval cost (last-10)", "Episodes cost > 25", "% episodes cost > 25"];
    assert_eq!(header[9..13], cost_header, "{md}");
    assert_eq!(
        row[9..13],
        ["0.150 ± 0.000 [0.150, 0.150]", "4.0 ± 0.0 [4.0, 4.0]", "1 ± 0.0 [1, 1]", "50.0 ± 0.0 [50.0, 50.0]"]
    );
    for kind in ["cost", "eval_cost"] {
        assert!(plots.join(format!("SafetyHopperVelocity-v1_sac_{kind}.svg")).is_file(), "{kind}");
        assert!(!plots.join(format!("Hopper-v5_sac_{kind}.svg")).exists(), "{kind}");
    }
}

/// `defender train` records its task's episode cost limit in summary.json (a velocity task's 25,
/// none for a crash task), and the report reads a real run of it with the cost columns.
#[test]
fn train_records_the_cost_limit_and_the_report_reads_the_run() {
    let root = scratch("train_limit");
    let summary = |dir: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
    };
    let mut limits = Vec::new();
    for env in ["SafetyHopperVelocity-v1", "Hopper-v5"] {
        let dir = root.join(env);
        // 300 random steps (learning starts later): a run in well under a second.
        let out = defender(&["train", "--env", env, "--steps", "300", "--out", dir.to_str().unwrap()]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        limits.push(summary(&dir).get("episode_cost_limit").cloned());
    }
    assert_eq!(limits, [Some(serde_json::json!(25.0)), None]);
    let out = defender(&["report", root.join("SafetyHopperVelocity-v1").to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("% episodes cost > 25"), "{}", text(&out.stdout));
}

#[test]
fn broken_run_directories_fail_with_the_file_named() {
    let root = scratch("broken");
    let dir = RunSpec::new("sac", 0, None).write(&root);
    std::fs::write(dir.join("summary.json"), "{\"complete\": tru").unwrap();
    let out = defender(&["report", root.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    assert!(stderr.starts_with(&format!("error: {}: ", dir.join("summary.json").display())), "{stderr}");
    assert!(out.stdout.is_empty());

    let out = defender(&["report", root.join("nowhere").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("nowhere: no such file or directory"));

    // An --out that cannot be written names the path, and says why once.
    let blocker = root.join("a-file");
    std::fs::write(&blocker, "").unwrap();
    let healthy = scratch("broken_out");
    RunSpec::new("sac", 0, None).write(&healthy);
    let target = blocker.join("report.md");
    let out = defender(&["report", healthy.to_str().unwrap(), "--out", target.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    assert!(stderr.starts_with(&format!("error: {}: ", blocker.display())), "{stderr}");
    assert_eq!(stderr.matches("os error").count(), 1, "the cause is said once: {stderr}");

    // Everything skipped: nothing to report is an error, not an empty table.
    std::fs::write(dir.join("summary.json"), "{\"complete\": false}").unwrap();
    let out = defender(&["report", root.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("error: no complete run to report"));
}

#[test]
fn help_has_an_example_and_bad_usage_is_rejected() {
    let out = defender(&["report", "--help"]);
    assert!(out.status.success());
    let help = text(&out.stdout);
    assert!(help.contains("Examples:\n  defender report runs/"), "{help}");
    assert!(
        help.contains("--format <FORMAT>") && help.contains("--plots <DIR>") && help.contains("--out <FILE>")
    );
    assert!(help.contains("--strict") && help.contains("--crash-window <STEPS>"), "{help}");
    let out = defender(&["report", ".", "--crash-window", "1000"]);
    assert_eq!(out.status.code(), Some(2), "--crash-window needs --plots");
    let out = defender(&["report", ".", "--plots", "p", "--crash-window", "0"]);
    assert_eq!(out.status.code(), Some(2), "a window of 0 steps");
    let out = defender(&["report"]);
    assert_eq!(out.status.code(), Some(2), "a run directory is required");
    let out = defender(&["report", ".", "--format", "html"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("invalid value 'html'"));
}

/// Real runs: a filter whose interventions are all checked beside a bare run. The report counts
/// the filtered episodes beside the crashes and judges the interventions from interventions.csv;
/// a malformed interventions.csv is an error naming the file and the line.
#[test]
fn real_checked_interventions_are_counted_and_judged() {
    let root = scratch("interventions");
    let (bare, arm) = (root.join("bare-s0"), root.join("margin-s0"));
    let env = "InvertedDoublePendulum-v5";
    // 500 random steps (learning starts later): well under a second each.
    let train = |extra: &[&str], dir: &Path| {
        let mut args = vec!["train", "--env", env, "--steps", "500", "--out", dir.to_str().unwrap()];
        args.extend(extra);
        let out = defender(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
    };
    train(&[], &bare);
    train(&["--trigger", "margin", "--task-margin", "0.5", "--check-every", "1"], &arm);
    let count = |dir: &Path, outcome: &str| {
        let metrics = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
        metrics.lines().filter(|l| l.split(',').nth(4) == Some(outcome)).count() as f64
    };
    let interventions = std::fs::read_to_string(arm.join("interventions.csv")).unwrap();
    let n = interventions.lines().count() as f64 - 1.0;
    assert!(n > 0.0 && n == count(&arm, "filtered"), "{interventions}");

    let out = defender(&["report", root.to_str().unwrap(), "--format", "csv"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    let names: Vec<&str> = defender_report::CSV_HEADER.split(',').collect();
    // The arm's label has commas (quoted): read its fields from the end, where ours are.
    let field = |line: &str, name: &str| -> String {
        let from_end = names.len() - names.iter().position(|c| *c == name).unwrap();
        let fields: Vec<&str> = line.split(',').collect();
        fields[fields.len() - from_end].to_string()
    };
    let lines: Vec<&str> = csv.lines().skip(1).collect();
    let arm_line = lines.iter().find(|l| l.contains("margin-trigger")).unwrap();
    assert_eq!(field(arm_line, "filtered_mean").parse::<f64>().unwrap(), n, "{csv}");
    assert_eq!(field(arm_line, "checked_mean").parse::<f64>().unwrap(), n, "every one checked: {csv}");
    let precision: f64 = field(arm_line, "precision_mean").parse().unwrap();
    assert!((0.0..=1.0).contains(&precision), "{csv}");
    let avoided = count(&bare, "crashed") - count(&arm, "crashed");
    let per: Option<f64> = field(arm_line, "interventions_per_crash_avoided").parse().ok();
    if avoided > 0.0 {
        assert!((per.unwrap() - n / avoided).abs() < 1e-9, "{csv}");
    } else {
        assert_eq!(per, None, "{csv}");
    }
    let out = defender(&["report", root.to_str().unwrap()]);
    let md = text(&out.stdout);
    for column in
        ["Filtered (interventions)", "Precision", "Lead (median steps)", "Interventions / crash avoided"]
    {
        assert!(md.contains(column), "{column}: {md}");
    }

    let mut lines: Vec<&str> = interventions.lines().collect();
    lines[1] = "1,2,3";
    std::fs::write(arm.join("interventions.csv"), lines.join("\n")).unwrap();
    let out = defender(&["report", root.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    let file = arm.join("interventions.csv");
    assert!(stderr.starts_with(&format!("error: {}:2: 3 fields", file.display())), "{stderr}");
    assert!(out.stdout.is_empty());
}
