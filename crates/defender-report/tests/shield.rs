//! The shielded evaluation (a DEFENDER run's evaluations with the filter kept, `eval.csv`'s
//! `shield_*` columns) beside the unfiltered one in every format, against hand-computed values:
//! on a crash task, on a cost task (with its cost), and absent from tables without it.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use common::{A, RunSpec, paper_fixture};
use defender_report::{CSV_HEADER, Format, Table, TableOptions, load_runs, render};

const VELOCITY: &str = "SafetyHopperVelocity-v1";

fn table(root: &std::path::Path, options: &TableOptions) -> Table {
    let set = load_runs(&[root]).unwrap();
    assert!(set.skipped.is_empty(), "{:?}", set.skipped);
    Table::from_runs_with(&set.runs, options)
}

fn cells(line: &str) -> Vec<String> {
    line.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// On `env`: bare SAC seeds 0-1 (no shield), and DEFENDER (strategy A) seeds 0-2:
/// - seed 0: 12 evaluations, shielded returns 0, 0, then 1..10 (last 10: 5.5), costs 9, 9, then
///   2 each (2), the filter ending all episodes of the first two and half of the others (50%);
/// - seed 1: 3 evaluations, shielded returns 2, 4, 6 (4), costs 1, 2, 3 (2), ended 0, 0, 0.3 (10%);
/// - seed 2: no shielded evaluation (a run from before them): left out of the shielded columns.
fn fixture(root: &std::path::Path, env: &'static str) {
    for seed in 0..2 {
        RunSpec::new("sac", seed, None).env(env).eval_costs(&[0.0; 4]).write(root);
    }
    let twelve: Vec<(f64, f64, f64)> = [(0.0, 9.0, 1.0), (0.0, 9.0, 1.0)]
        .into_iter()
        .chain((1..=10).map(|k| (f64::from(k), 2.0, 0.5)))
        .collect();
    RunSpec::new("sac", 0, A).env(env).evals(&[(50.0, 1000.0); 12]).shield(&twelve).write(root);
    let three = [(2.0, 1.0, 0.0), (4.0, 2.0, 0.0), (6.0, 3.0, 0.3)];
    RunSpec::new("sac", 1, A).env(env).evals(&[(50.0, 1000.0); 3]).shield(&three).write(root);
    RunSpec::new("sac", 2, A).env(env).eval_costs(&[0.0; 4]).write(root);
}

#[test]
fn a_crash_task_shows_the_shielded_return_and_share_beside_the_last_evaluations() {
    let root = tempfile::tempdir().unwrap();
    fixture(root.path(), "Hopper-v5");
    let table = table(root.path(), &TableOptions::default());
    assert_eq!(table.rows.len(), 2);
    assert!(table.rows[0].shield.is_none(), "a bare row has none");
    let shield = table.rows[1].shield.unwrap();
    assert_eq!(shield.eval.stat.n, 2, "over the seeds that have one");
    assert!(close(shield.eval.stat.mean, 4.75) && close(shield.eval.stat.std, 0.75), "{shield:?}");
    assert_eq!((shield.eval.ci.lo, shield.eval.ci.hi), (4.0, 5.5));
    assert!(close(shield.ended_pct.stat.mean, 30.0), "{shield:?}");
    assert!(close(shield.cost.stat.mean, 2.0));

    let md = render(&table, Format::Markdown);
    let header = cells(md.lines().find(|l| l.starts_with("| Algorithm")).unwrap());
    let at =
        |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}: {header:?}"));
    assert_eq!(at("Shielded eval (last-10)"), at("Last-10 eval") + 1);
    assert_eq!(at("% Shield-ended"), at("Last-10 eval") + 2);
    assert!(!header.iter().any(|h| h.starts_with("Shielded cost")), "a crash task has no cost columns");
    let lines: Vec<Vec<String>> = md.lines().filter(|l| l.starts_with("| SAC")).map(cells).collect();
    assert_eq!(lines[0][at("Shielded eval (last-10)")], "-", "the bare row");
    assert_eq!(lines[1][at("Shielded eval (last-10)")], "5 ± 0.8 [4, 6]");
    assert_eq!(lines[1][at("% Shield-ended")], "30.0 ± 20.0 [10.0, 50.0]");
    assert!(md.contains("Shielded columns (DEFENDER runs)"), "the legend says what they are");

    let tex = render(&table, Format::Latex);
    assert!(tex.contains("Shielded eval (last-10) & \\% Shield-ended & \\% Crash"), "{tex}");
    assert!(tex.contains("5$\\pm$0.8 & 30.0$\\pm$20.0"), "{tex}");
    assert!(tex.contains(" & - & - & "), "the bare row's shielded cells: {tex}");

    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let col = |row: &[&str], name: &str| row[header.iter().position(|h| *h == name).unwrap()].to_string();
    assert!(rows.iter().all(|r| r.len() == header.len()));
    assert_eq!(col(&rows[0], "shield_eval_last10_mean"), "", "the bare row");
    assert_eq!(col(&rows[1], "shield_eval_last10_mean"), "4.75");
    assert_eq!(col(&rows[1], "shield_ended_pct_mean"), "30");
    assert_eq!(col(&rows[1], "shield_eval_cost_last10_mean"), "", "a crash task's cost is its crashes");
}

#[test]
fn a_cost_task_shows_the_shielded_cost_beside_the_evaluation_cost() {
    let root = tempfile::tempdir().unwrap();
    fixture(root.path(), VELOCITY);
    let options = TableOptions { cost_limits: [(VELOCITY, 25.0)].into_iter().collect() };
    let table = table(root.path(), &options);
    let md = render(&table, Format::Markdown);
    let header = cells(md.lines().find(|l| l.starts_with("| Algorithm")).unwrap());
    let at =
        |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}: {header:?}"));
    assert_eq!(at("Shielded cost (last-10)"), at("Eval cost (last-10)") + 1);
    assert_eq!(at("Shielded eval (last-10)"), at("Last-10 eval") + 1);
    let lines: Vec<Vec<String>> = md.lines().filter(|l| l.starts_with("| SAC")).map(cells).collect();
    assert_eq!(lines[1][at("Shielded cost (last-10)")], "2.0 ± 0.0 [2.0, 2.0]");
    assert_eq!(lines[0][at("Shielded cost (last-10)")], "-");

    let tex = render(&table, Format::Latex);
    assert!(tex.contains("Eval cost (last-10) & Shielded cost (last-10) & Cost $>$ 25"), "{tex}");
    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let row: Vec<&str> = csv.lines().nth(2).unwrap().split(',').collect();
    assert_eq!(row[header.iter().position(|h| *h == "shield_eval_cost_last10_mean").unwrap()], "2");
}

#[test]
fn tables_without_a_shielded_evaluation_keep_their_columns() {
    let root = tempfile::tempdir().unwrap();
    paper_fixture(root.path());
    let table = table(root.path(), &TableOptions::default());
    assert!(table.rows.iter().all(|r| r.shield.is_none()));
    for format in [Format::Markdown, Format::Latex] {
        assert!(!render(&table, format).contains("Shield"), "{format:?}");
    }
}

#[test]
fn the_plots_add_the_shielded_evaluation_for_the_configurations_with_a_filter() {
    let root = tempfile::tempdir().unwrap();
    let runs = root.path().join("runs");
    for seed in 0..2 {
        RunSpec::new("sac", seed, None).env(VELOCITY).eval_costs(&[30.0, 40.0, 30.0, 40.0]).write(&runs);
        let shield = [(10.0, 5.0 + seed as f64, 0.5), (20.0, 7.0, 0.25)];
        RunSpec::new("sac", seed, A)
            .env(VELOCITY)
            .evals(&[(50.0, 1000.0); 2])
            .eval_costs(&[9.0, 8.0])
            .shield(&shield)
            .write(&runs);
    }
    let set = load_runs(&[&runs]).unwrap();
    let options = defender_report::PlotOptions {
        cost_limits: [(VELOCITY, 25.0)].into_iter().collect(),
        ..defender_report::PlotOptions::default()
    };
    let plots = defender_report::draw_plots(&set.runs, root.path().join("p"), &options).unwrap();
    assert!(plots.notes.is_empty(), "{:?}", plots.notes);
    let read = |kind: &str| {
        std::fs::read_to_string(root.path().join(format!("p/{VELOCITY}_sac_{kind}.svg"))).unwrap()
    };
    let svg = read("shield_eval");
    assert!(svg.contains("evaluation return with the filter kept"), "{svg}");
    assert!(svg.contains(&format!("{} [2 seeds]", A.unwrap().0)), "the filtered configuration: {svg}");
    assert!(!svg.contains("(bare)"), "no filter to keep in a bare run: {svg}");
    let svg = read("shield_eval_cost");
    assert!(
        svg.contains("evaluation cost with the filter kept") && svg.contains("episode cost limit (25)"),
        "{svg}"
    );
    // The unfiltered evaluation cost plot still shows both configurations.
    assert!(read("eval_cost").contains("(bare)"));
}

#[test]
fn no_shielded_plot_without_a_shielded_evaluation() {
    let root = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, A).env(VELOCITY).eval_costs(&[1.0, 2.0, 3.0, 4.0]).write(root.path());
    let set = load_runs(&[root.path()]).unwrap();
    let plots = defender_report::draw_plots(&set.runs, root.path().join("p"), &Default::default()).unwrap();
    assert!(plots.files.iter().all(|p| !p.to_string_lossy().contains("shield")), "{:?}", plots.files);
}
