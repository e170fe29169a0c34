//! The share of evaluation episodes within the episode cost limit (from `eval_episodes.csv`),
//! beside the evaluation cost of a velocity task, against hand-computed values in every format;
//! absent from tables whose runs predate the file; a malformed file refused with its line.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use std::fmt::Write as _;
use std::path::Path;

use common::{A, RunSpec};
use defender_report::{CSV_HEADER, EVAL_EPISODES_HEADER, Format, Table, TableOptions, load_runs, render};

const VELOCITY: &str = "SafetyHopperVelocity-v1";

fn limits() -> TableOptions {
    TableOptions { cost_limits: [(VELOCITY, 25.0)].into_iter().collect() }
}

fn table(root: &Path) -> Table {
    let set = load_runs(&[root]).unwrap();
    assert!(set.skipped.is_empty(), "{:?}", set.skipped);
    Table::from_runs_with(&set.runs, &limits())
}

/// One evaluation's episodes: each one's cost, and its shielded cost if the run has a filter.
type Evaluation = Vec<(f64, Option<f64>)>;

/// Ten episodes, `within` of them costing at most 25 (0, 12.5 and exactly 25 in turn) and the
/// others more (26 and 40 in turn); shielded with the costs `shield` gives, if any.
fn ten(within: usize, shield: Option<usize>) -> Evaluation {
    let cost = |k: usize, n: usize| if k < n { [0.0, 12.5, 25.0][k % 3] } else { [26.0, 40.0][k % 2] };
    (0..10).map(|k| (cost(k, within), shield.map(|s| cost(k, s)))).collect()
}

/// Writes `dir/eval_episodes.csv` for evaluations made every 100 steps, as `RunSpec` writes
/// `eval.csv`; a shielded episode is stopped when its shielded cost is below its cost.
fn write_eval_episodes(dir: &Path, evaluations: &[Evaluation]) {
    let mut text = format!("{EVAL_EPISODES_HEADER}\n");
    for (i, evaluation) in evaluations.iter().enumerate() {
        for (k, (cost, shield)) in evaluation.iter().enumerate() {
            let shielded = shield.map_or(",,".to_string(), |s| format!("-3.5,{s},{}", u8::from(s < *cost)));
            writeln!(text, "{},{k},{}.5,{cost},{shielded}", 100 * (i + 1), 10 * k).unwrap();
        }
    }
    std::fs::write(dir.join("eval_episodes.csv"), text).unwrap();
}

/// On the velocity task (L = 25), evaluations of 10 episodes every 100 steps:
/// - bare SAC seed 0: 12 evaluations; the first two all over 25, then five keeping all 10
///   episodes within it and five keeping 6: over the last 10, 80 of 100 (0.8);
/// - bare seed 1: 3 evaluations keeping 10, 5 and 0: 15 of 30 (0.5);
/// - bare seed 2: no eval_episodes.csv (a run from before it): left out;
/// - DEFENDER (A) seed 0: 3 evaluations keeping 4, 6, 8 (18 of 30: 0.6), shielded 10, 9, 8
///   (27 of 30: 0.9); seed 1: all 30 within, shielded too (1.0, 1.0).
fn fixture(root: &Path) {
    let twelve: Vec<Evaluation> = (0..12)
        .map(|i| match i {
            0 | 1 => ten(0, None),
            2..=6 => ten(10, None),
            _ => ten(6, None),
        })
        .collect();
    let s0 = RunSpec::new("sac", 0, None)
        .env(VELOCITY)
        .evals(&[(50.0, 1000.0); 12])
        .eval_costs(&[20.0; 12])
        .write(root);
    write_eval_episodes(&s0, &twelve);
    let s1 = RunSpec::new("sac", 1, None)
        .env(VELOCITY)
        .evals(&[(50.0, 1000.0); 3])
        .eval_costs(&[10.0, 20.0, 30.0])
        .write(root);
    write_eval_episodes(&s1, &[ten(10, None), ten(5, None), ten(0, None)]);
    RunSpec::new("sac", 2, None).env(VELOCITY).eval_costs(&[5.0; 4]).write(root);
    let shield = [(10.0, 1.0, 0.1); 3];
    let a0 = RunSpec::new("sac", 0, A)
        .env(VELOCITY)
        .evals(&[(50.0, 1000.0); 3])
        .eval_costs(&[20.0; 3])
        .shield(&shield)
        .write(root);
    write_eval_episodes(&a0, &[ten(4, Some(10)), ten(6, Some(9)), ten(8, Some(8))]);
    let a1 = RunSpec::new("sac", 1, A)
        .env(VELOCITY)
        .evals(&[(50.0, 1000.0); 3])
        .eval_costs(&[1.0; 3])
        .shield(&shield)
        .write(root);
    write_eval_episodes(&a1, &[ten(10, Some(10)), ten(10, Some(10)), ten(10, Some(10))]);
}

fn cells(line: &str) -> Vec<String> {
    line.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn the_share_of_evaluation_episodes_within_the_limit_beside_the_evaluation_cost() {
    let root = tempfile::tempdir().unwrap();
    fixture(root.path());
    let table = table(root.path());
    assert_eq!(table.rows.len(), 2);
    let (bare, a) = (table.rows[0].costs.unwrap(), table.rows[1].costs.unwrap());
    let within = bare.eval_within_limit.unwrap();
    assert_eq!(within.stat.n, 2, "over the seeds with eval_episodes.csv");
    assert!(close(within.stat.mean, 0.65) && close(within.stat.std, 0.15), "{within:?}");
    assert_eq!((within.ci.lo, within.ci.hi), (0.5, 0.8));
    assert_eq!(bare.shield_within_limit, None, "no filter, no shielded episodes");
    let within = a.eval_within_limit.unwrap();
    assert!(close(within.stat.mean, 0.8) && close(within.stat.std, 0.2), "{within:?}");
    let shielded = a.shield_within_limit.unwrap();
    assert!(close(shielded.stat.mean, 0.95) && close(shielded.stat.std, 0.05), "{shielded:?}");
    assert_eq!((shielded.ci.lo, shielded.ci.hi), (0.9, 1.0));
    assert!(
        table.notes.iter().any(|n| n.starts_with("Eval episodes cost ≤ 25 of SafetyHopperVelocity-v1 SAC")
            && n.contains("no eval_episodes.csv for seed(s) 2; the shares are over the other 2 seed(s)")),
        "{:?}",
        table.notes
    );
    assert_eq!(table.notes.len(), 1, "the files match eval.csv: {:?}", table.notes);

    let md = render(&table, Format::Markdown);
    let header = cells(md.lines().find(|l| l.starts_with("| Algorithm")).unwrap());
    let at =
        |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}: {header:?}"));
    assert_eq!(at("Eval episodes cost ≤ 25 (last-10)"), at("Eval cost (last-10)") + 1);
    assert_eq!(at("Shielded cost (last-10)"), at("Eval cost (last-10)") + 2);
    assert_eq!(at("Shielded episodes cost ≤ 25 (last-10)"), at("Shielded cost (last-10)") + 1);
    assert_eq!(at("Episodes cost > 25"), at("Shielded episodes cost ≤ 25 (last-10)") + 1);
    let lines: Vec<Vec<String>> = md.lines().filter(|l| l.starts_with("| SAC")).map(cells).collect();
    assert_eq!(lines[0][at("Eval episodes cost ≤ 25 (last-10)")], "0.65 ± 0.15 [0.50, 0.80]", "{md}");
    assert_eq!(lines[0][at("Shielded episodes cost ≤ 25 (last-10)")], "-", "the bare row");
    assert_eq!(lines[1][at("Eval episodes cost ≤ 25 (last-10)")], "0.80 ± 0.20 [0.60, 1.00]");
    assert_eq!(lines[1][at("Shielded episodes cost ≤ 25 (last-10)")], "0.95 ± 0.05 [0.90, 1.00]");
    assert!(md.contains("Eval episodes cost ≤ L (last-10) (tasks with a cost limit L"), "the legend: {md}");

    let csv = render(&table, Format::Csv);
    let names: Vec<&str> = CSV_HEADER.split(',').collect();
    let lines: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let field = |row: usize, name: &str| lines[row][names.iter().position(|n| *n == name).unwrap()];
    assert!(lines.iter().all(|l| l.len() == names.len()));
    assert_eq!(field(0, "eval_within_limit_last10_mean"), "0.65");
    assert_eq!(field(0, "eval_within_limit_last10_ci_lo"), "0.5");
    assert_eq!(field(0, "eval_within_limit_last10_ci_hi"), "0.8");
    assert_eq!(field(0, "shield_eval_within_limit_last10_mean"), "");
    assert!(close(field(1, "eval_within_limit_last10_mean").parse().unwrap(), 0.8));
    assert!(close(field(1, "shield_eval_within_limit_last10_mean").parse().unwrap(), 0.95));
    assert_eq!(*names.last().unwrap(), "shield_eval_within_limit_last10_ci_hi", "appended at the end");

    let tex = render(&table, Format::Latex);
    let cost_header = "& Cost rate & Eval cost (last-10) & Eval ep. cost $\\leq$ 25 & Shielded cost (last-10) \
                       & Shielded ep. cost $\\leq$ 25 & Cost $>$ 25 & \\% cost $>$ 25";
    assert!(tex.contains(cost_header), "{tex}");
    // 5 columns, 2 shielded, Filtered, and 4 + 1 cost columns with 2 shares.
    assert!(tex.contains("\\multicolumn{15}{c}{SafetyHopperVelocity-v1}"), "{tex}");
    assert!(tex.contains(" & 0.65$\\pm$0.15 & - & - & "), "the bare row: {tex}");
    assert!(tex.contains(" & 0.80$\\pm$0.20 & 1.0$\\pm$0.0 & 0.95$\\pm$0.05 & "), "{tex}");
    assert!(tex.contains("Eval ep. cost $\\leq$ L: the share of the evaluation episodes"), "{tex}");
}

#[test]
fn runs_without_the_file_and_crash_tasks_get_no_share() {
    let root = tempfile::tempdir().unwrap();
    for seed in 0..2 {
        RunSpec::new("sac", seed, None).env(VELOCITY).eval_costs(&[3.0; 4]).write(root.path());
    }
    // A crash task has no limit: its file is read, but there is no share to give.
    let hopper = RunSpec::new("sac", 0, None).write(root.path());
    write_eval_episodes(&hopper, &[ten(10, None), ten(10, None), ten(10, None), ten(10, None)]);
    let table = table(root.path());
    assert!(table.rows.iter().all(|r| r.costs.is_none_or(|c| c.eval_within_limit.is_none())));
    let md = render(&table, Format::Markdown);
    assert!(!md.contains("Eval episodes cost") && !md.contains("≤"), "{md}");
    let tex = render(&table, Format::Latex);
    assert!(
        !tex.contains("Eval ep.") && tex.contains("\\multicolumn{9}{c}{SafetyHopperVelocity-v1}"),
        "{tex}"
    );
    let names: Vec<&str> = CSV_HEADER.split(',').collect();
    let first = names.iter().position(|n| *n == "eval_within_limit_last10_mean").unwrap();
    for line in render(&table, Format::Csv).lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        assert!(fields[first..].iter().all(|f| f.is_empty()), "{line}");
    }
    assert!(table.notes.is_empty(), "{:?}", table.notes);
}

#[test]
fn a_file_that_does_not_hold_eval_csvs_last_evaluations_is_noted() {
    let root = tempfile::tempdir().unwrap();
    // eval.csv: 4 evaluations of 10 episodes at 100..400 steps. Seed 0's file holds the last two
    // only (a run resumed from a checkpoint made before the file existed); seed 1's has 5
    // episodes in its last evaluation.
    let s0 = RunSpec::new("sac", 0, None).env(VELOCITY).eval_costs(&[3.0; 4]).write(root.path());
    let text = std::fs::read_to_string(s0.join("eval.csv")).unwrap();
    assert!(text.lines().nth(1).unwrap().starts_with("100,"), "{text}");
    let mut body = format!("{EVAL_EPISODES_HEADER}\n");
    for steps in [300, 400] {
        (0..10).for_each(|k| writeln!(body, "{steps},{k},1,{},,,", if k < 5 { 0 } else { 30 }).unwrap());
    }
    std::fs::write(s0.join("eval_episodes.csv"), body).unwrap();
    let s1 = RunSpec::new("sac", 1, None).env(VELOCITY).eval_costs(&[3.0; 4]).write(root.path());
    let mut four = vec![ten(10, None); 4];
    four[3].truncate(5);
    write_eval_episodes(&s1, &four);
    let table = table(root.path());
    let within = table.rows[0].costs.unwrap().eval_within_limit.unwrap();
    assert!(close(within.stat.mean, 0.75), "seed 0 over its 2 evaluations (0.5), seed 1 1.0: {within:?}");
    let notes = table.notes.join("\n");
    assert!(
        notes.contains("seed 0: eval_episodes.csv holds 2 evaluation(s), fewer than the last 4"),
        "{notes}"
    );
    assert!(
        notes.contains("seed 1: the last 4 evaluations of eval_episodes.csv differ from eval.csv's"),
        "{notes}"
    );
}

#[test]
fn a_malformed_eval_episodes_file_is_an_error_naming_the_file_and_line() {
    let root = tempfile::tempdir().unwrap();
    let run = RunSpec::new("sac", 0, A).env(VELOCITY).eval_costs(&[3.0; 4]).write(root.path());
    let path = run.join("eval_episodes.csv");
    let good = "100,0,10.5,3,,,";
    for (line, needle) in [
        ("100,1,10.5,many,,,", "column cost: cannot read \"many\""),
        ("100,1,10.5,inf,,,", "column cost: inf is not a finite number"),
        ("100,1,nan,3,,,", "column return: NaN is not a finite number"),
        ("100,1,10.5,3,2.5,,1", "are filled together or left empty together"),
        ("100,1,10.5,3,2.5,1,yes", "column shield_stopped: \"yes\" is not 0 or 1"),
        ("100,1,10.5,3,2.5,nan,0", "column shield_cost: NaN is not a finite number"),
        ("100,2,10.5,3,,,", "episode 2 out of order: expected 1 (or 0, starting the next evaluation)"),
        ("200,1,10.5,3,,,", "episode 1 out of order: expected 0"),
        ("50,0,10.5,3,,,", "total_steps 50 decreases (previous row: 100)"),
        ("-100,1,10.5,3,,,", "column total_steps: cannot read \"-100\""),
        ("100,1,10.5", "3 fields, the header has 7"),
    ] {
        std::fs::write(&path, format!("{EVAL_EPISODES_HEADER}\n{good}\n{line}\n")).unwrap();
        let err = load_runs(&[root.path()]).unwrap_err().to_string();
        assert!(err.starts_with(&format!("{}:3: ", path.display())), "{err}");
        assert!(err.contains(needle), "{needle}: {err}");
    }
    std::fs::write(&path, format!("{EVAL_EPISODES_HEADER}\n100,3,10.5,3,,,\n")).unwrap();
    let err = load_runs(&[root.path()]).unwrap_err().to_string();
    assert!(err.contains(":2: episode 3 out of order: expected 0, the first episode"), "{err}");
    std::fs::write(&path, "total_steps,episode,return\n100,0,1\n").unwrap();
    let err = load_runs(&[root.path()]).unwrap_err().to_string();
    assert!(err.contains(&path.display().to_string()) && err.contains("missing column \"cost\""), "{err}");
}
