//! The cost measures of a per-step cost task (Safety-Gymnasium's velocity tasks): cost rate,
//! evaluation cost (last-10) and % episodes over the limit, against hand-computed values; and
//! the crash tasks' tables, which keep their columns.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use common::{A, RunSpec, paper_fixture};
use defender_report::{CSV_HEADER, CostLimits, Format, Row, Table, TableOptions, load_runs, render};

const VELOCITY: &str = "SafetyHopperVelocity-v1";

fn limits() -> TableOptions {
    TableOptions {
        cost_limits: [(VELOCITY, 25.0), ("SafetyWalker2dVelocity-v1", 25.0)].into_iter().collect(),
    }
}

/// Bare SAC on the velocity task, seeds 0-2, three 100-step episodes each (300 environment
/// steps, none filtered):
/// - seed 0: episode costs 30, 10, 0 (1 of 3 over 25); 12 evaluations costing 100, 100, then
///   1, 2, ..., 10 (the last 10 average 5.5);
/// - seed 1: 26, 25, 5 (1 of 3 over: 25 is at the limit, not over it); evaluations 2, 4, 6 (4);
/// - seed 2: no cost; evaluations 0, 0, 0.
fn velocity_fixture(root: &std::path::Path) {
    let twelve: Vec<f64> = [100.0, 100.0].into_iter().chain((1..=10).map(f64::from)).collect();
    RunSpec::new("sac", 0, None)
        .env(VELOCITY)
        .outcomes(3, 0, 0)
        .costs(&[30.0, 10.0, 0.0])
        .evals(&[(50.0, 1000.0); 12])
        .eval_costs(&twelve)
        .write(root);
    RunSpec::new("sac", 1, None)
        .env(VELOCITY)
        .outcomes(3, 0, 0)
        .costs(&[26.0, 25.0, 5.0])
        .eval_costs(&[2.0, 4.0, 6.0])
        .write(root);
    RunSpec::new("sac", 2, None)
        .env(VELOCITY)
        .outcomes(3, 0, 0)
        .costs(&[0.0; 3])
        .eval_costs(&[0.0; 3])
        .write(root);
}

fn table(root: &std::path::Path, options: &TableOptions) -> Table {
    let set = load_runs(&[root]).unwrap();
    assert!(set.skipped.is_empty(), "{:?}", set.skipped);
    Table::from_runs_with(&set.runs, options)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

fn cells(line: &str) -> Vec<String> {
    line.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
}

#[test]
fn velocity_runs_get_the_cost_columns_with_hand_computed_values() {
    let root = tempfile::tempdir().unwrap();
    velocity_fixture(root.path());
    let table = table(root.path(), &limits());
    assert_eq!(table.rows.len(), 1);
    let costs = table.rows[0].costs.unwrap();
    assert_eq!(costs.limit, 25.0);
    // Cost rate: 40/300, 56/300, 0.
    assert!(close(costs.cost_rate.stat.mean, 96.0 / 900.0), "{costs:?}");
    assert!(close(costs.cost_rate.ci.lo, 0.0) && close(costs.cost_rate.ci.hi, 56.0 / 300.0));
    // Evaluation cost (last-10): 5.5, 4, 0.
    let eval = costs.eval_cost.unwrap();
    assert!(close(eval.stat.mean, 9.5 / 3.0), "{eval:?}");
    assert_eq!((eval.ci.lo, eval.ci.hi), (0.0, 5.5));
    // Episodes over 25: 1 of 3, 1 of 3, 0 of 3 -> counts 1, 1, 0; % 33.3, 33.3, 0 -> mean 22.2,
    // std (100/3) sqrt(2)/3.
    let count = costs.over_limit;
    assert!(close(count.stat.mean, 2.0 / 3.0) && close(count.stat.std, 2f64.sqrt() / 3.0), "{count:?}");
    assert_eq!((count.ci.lo, count.ci.hi), (0.0, 1.0));
    let over = costs.over_limit_pct;
    assert!(close(over.stat.mean, 200.0 / 9.0) && close(over.stat.std, 100.0 / 3.0 * 2f64.sqrt() / 3.0));
    assert!(close(over.ci.hi, 100.0 / 3.0) && over.ci.lo == 0.0);

    let md = render(&table, Format::Markdown);
    let header = md.lines().find(|l| l.starts_with("| Algorithm")).unwrap();
    assert_eq!(
        cells(header),
        [
            "Algorithm",
            "Safe",
            "Unsafe",
            "Acc Reward (final eval)",
            "Best episode (paper's Acc Reward)",
            "Last-10 eval",
            "% Crash",
            "Crashes",
            "Crashes / 1k env steps",
            "Cost rate",
            "Eval cost (last-10)",
            "Episodes cost > 25",
            "% episodes cost > 25",
            "Standing %",
            "% Time",
            "Seeds"
        ]
    );
    let row = cells(md.lines().find(|l| l.starts_with("| SAC")).unwrap());
    assert_eq!(row[9], "0.107 ± 0.079 [0.000, 0.187]", "{md}");
    assert_eq!(row[10], "3.2 ± 2.3 [0.0, 5.5]");
    assert_eq!(row[11], "1 ± 0.5 [0, 1]");
    assert_eq!(row[12], "22.2 ± 15.7 [0.0, 33.3]");
    assert!(md.contains("Eval cost (last-10): the evaluation episodes' mean cost"), "the legend says it");

    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let line: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(line.len(), header.len());
    let col = |name: &str| line[header.iter().position(|h| *h == name).unwrap()];
    let num = |name: &str| col(name).parse::<f64>().unwrap();
    assert_eq!(col("episode_cost_limit"), "25");
    assert!(close(num("cost_rate_mean"), 96.0 / 900.0));
    assert!(close(num("eval_cost_last10_mean"), 9.5 / 3.0));
    assert_eq!(num("eval_cost_last10_ci_hi"), 5.5);
    assert!(close(num("over_limit_mean"), 2.0 / 3.0));
    assert_eq!(num("over_limit_ci_hi"), 1.0);
    assert!(close(num("over_limit_pct_mean"), 200.0 / 9.0));
    assert!(close(num("over_limit_pct_ci_hi"), 100.0 / 3.0));

    let tex = render(&table, Format::Latex);
    assert!(tex.contains("\\multicolumn{9}{c}{SafetyHopperVelocity-v1}"), "{tex}");
    let cost_header = "& Cost rate & Eval cost (last-10) & Cost $>$ 25 & \\% cost $>$ 25 & \\% Time";
    assert!(tex.contains(cost_header), "{tex}");
    assert!(tex.contains("& 0.107$\\pm$0.079 & 3.2$\\pm$2.3 & 1$\\pm$0.5 & 22.2$\\pm$15.7 & "), "{tex}");
}

#[test]
fn the_cost_rate_leaves_filtered_steps_out() {
    let root = tempfile::tempdir().unwrap();
    // Four 100-step episodes, the first one filtered (its last step never reached the
    // environment): 399 environment steps, cost 40; one episode of four over the limit.
    RunSpec::new("sac", 0, A)
        .env(VELOCITY)
        .outcomes(4, 0, 1)
        .costs(&[30.0, 0.0, 0.0, 10.0])
        .eval_costs(&[1.0; 4])
        .write(root.path());
    let table = table(root.path(), &limits());
    let costs = table.rows[0].costs.unwrap();
    assert!(close(costs.cost_rate.stat.mean, 40.0 / 399.0), "{costs:?}");
    assert_eq!((costs.over_limit.stat.mean, costs.over_limit_pct.stat.mean), (1.0, 25.0));
    assert_eq!(costs.eval_cost.unwrap().stat.mean, 1.0);
    let run = &load_runs(&[root.path()]).unwrap().runs[0];
    let curve = run.cumulative_cost();
    assert_eq!(curve, vec![(99, 30.0), (199, 30.0), (299, 30.0), (399, 40.0)]);
}

#[test]
fn without_a_limit_there_are_no_cost_columns_unless_the_summary_records_one() {
    let root = tempfile::tempdir().unwrap();
    velocity_fixture(root.path());
    let table = table(root.path(), &TableOptions::default());
    assert!(table.rows[0].costs.is_none());
    let md = render(&table, Format::Markdown);
    assert!(!md.contains("Cost rate") && !md.contains("Eval cost"), "{md}");

    // A run whose summary.json records its task's limit (as `defender train` writes it) brings
    // it along.
    let other = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, None)
        .env(VELOCITY)
        .outcomes(2, 0, 0)
        .costs(&[40.0, 0.0])
        .eval_costs(&[3.0, 5.0])
        .cost_limit(25.0)
        .write(other.path());
    let set = load_runs(&[other.path()]).unwrap();
    assert_eq!(set.runs[0].summary.episode_cost_limit, Some(25.0));
    let costs = Table::from_runs(&set.runs).rows[0].costs.unwrap();
    assert_eq!((costs.limit, costs.over_limit_pct.stat.mean), (25.0, 50.0));
    assert_eq!(costs.eval_cost.unwrap().stat.mean, 4.0);
    // A limit given for the task wins over the recorded one.
    let options = TableOptions { cost_limits: [(VELOCITY, 50.0)].into_iter().collect() };
    let costs = Table::from_runs_with(&set.runs, &options).rows[0].costs.unwrap();
    assert_eq!((costs.limit, costs.over_limit_pct.stat.mean), (50.0, 0.0));
}

#[test]
fn a_crash_task_table_is_unchanged_by_cost_limits() {
    let root = tempfile::tempdir().unwrap();
    paper_fixture(root.path());
    let set = load_runs(&[root.path()]).unwrap();
    let plain = Table::from_runs(&set.runs);
    let with = Table::from_runs_with(&set.runs, &limits());
    assert!(with.rows.iter().all(|r| r.costs.is_none()));
    for format in [Format::Markdown, Format::Latex, Format::Csv] {
        assert_eq!(render(&plain, format), render(&with, format), "{format:?}");
    }
    let md = render(&with, Format::Markdown);
    assert!(!md.contains("Cost rate") && !md.contains("Cost columns"), "{md}");
    // The CSV's cost columns (at its end, up to the filtered episodes' count, which the
    // DEFENDER rows fill) are empty.
    let csv = render(&with, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let first = header.iter().position(|h| *h == "episode_cost_limit").unwrap();
    let filtered = header.iter().position(|h| *h == "filtered_mean").unwrap();
    assert_eq!(header[first - 1], "crashes_per_1k_env_steps_ci_hi", "appended after the old columns");
    for line in csv.lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        assert!(fields[first..filtered].iter().all(|f| f.is_empty()), "{line}");
    }
}

#[test]
fn a_mixed_report_gives_the_cost_columns_to_the_cost_task_only() {
    let root = tempfile::tempdir().unwrap();
    velocity_fixture(root.path());
    RunSpec::new("sac", 0, None).outcomes(3, 1, 0).write(root.path());
    let table = table(root.path(), &limits());
    let by_env = |env: &str| -> &Row { table.rows.iter().find(|r| r.env == env).unwrap() };
    assert!(by_env("Hopper-v5").costs.is_none() && by_env(VELOCITY).costs.is_some());
    let md = render(&table, Format::Markdown);
    let headers: Vec<Vec<String>> = md.lines().filter(|l| l.starts_with("| Algorithm")).map(cells).collect();
    assert_eq!(headers.len(), 2, "{md}");
    assert_eq!(headers[0].len(), 12, "Hopper-v5 first, its columns as ever: {:?}", headers[0]);
    assert_eq!(headers[1].len(), 16, "{:?}", headers[1]);
    let tex = render(&table, Format::Latex);
    assert!(
        tex.contains("\\multicolumn{5}{c}{Hopper-v5} & \\multicolumn{9}{c}{SafetyHopperVelocity-v1}"),
        "{tex}"
    );
    assert!(tex.contains("\\cmidrule(lr){3-7} \\cmidrule(lr){8-16}"), "{tex}");
    assert!(tex.contains(&format!("\\begin{{tabular}}{{ll{}}}", "r".repeat(14))), "{tex}");
}

#[test]
fn cost_limits_collect_by_task() {
    let limits: CostLimits = [(VELOCITY, 25.0)].into_iter().collect();
    assert_eq!(limits.get(VELOCITY), Some(25.0));
    assert_eq!(limits.get("Hopper-v5"), None);
}
