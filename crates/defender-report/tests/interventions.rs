//! The interventions' columns (docs/SPEC.md section 15) against hand-computed values, on run
//! directories with an `interventions.csv`, and a malformed file refused with its line.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use std::fmt::Write as _;
use std::path::Path;

use common::{A, B, RunSpec};
use defender_report::{CSV_HEADER, Format, INTERVENTIONS_HEADER, Row, Table, load_runs, render};

/// One checked intervention: whether its continuation failed, and after how many steps.
type Check = Option<(bool, Option<u64>)>;

/// Writes `dir/interventions.csv`: one intervention per filtered episode of a run written by
/// `RunSpec::outcomes(_, crashed, _)` (episodes `crashed`, `crashed + 1`, ..., each of 100 steps),
/// checked as `checks` says.
fn write_interventions(dir: &Path, crashed: u64, checks: &[Check]) {
    let mut text = format!("{INTERVENTIONS_HEADER}\n");
    for (i, check) in checks.iter().enumerate() {
        let episode = crashed + i as u64;
        let (checked, fail, steps, continuation) = match check {
            None => (0, String::new(), String::new(), 0),
            Some((fail, steps)) => (
                1,
                u8::from(*fail).to_string(),
                steps.map(|s| s.to_string()).unwrap_or_default(),
                steps.unwrap_or(1000),
            ),
        };
        writeln!(
            text,
            "{},{episode},{i},100,0,{checked},{fail},{steps},{continuation},-50.5,0",
            100 * (episode + 1)
        )
        .unwrap();
    }
    std::fs::write(dir.join("interventions.csv"), text).unwrap();
}

fn table(root: &Path) -> Table {
    Table::from_runs(&load_runs(&[root]).unwrap().runs)
}

fn row<'t>(table: &'t Table, strategy: Option<&str>) -> &'t Row {
    table.rows.iter().find(|r| r.filter.as_ref().map(|f| f.strategy.as_str()) == strategy).unwrap()
}

/// The Markdown table's cell of column `column` in the first line containing `line`.
fn md_cell(md: &str, line: &str, column: &str) -> String {
    let cells = |l: &str| -> Vec<String> {
        l.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
    };
    let header = cells(md.lines().find(|l| l.starts_with("| Algorithm")).unwrap());
    let k = header.iter().position(|h| h == column).unwrap_or_else(|| panic!("no column {column}: {md}"));
    cells(md.lines().find(|l| l.contains(line)).unwrap_or_else(|| panic!("no line {line}: {md}")))[k].clone()
}

fn close(value: f64, expected: f64) -> bool {
    (value - expected).abs() < 1e-9
}

/// Every run has 12 episodes (one budget: one table). Bare SAC crashes 6 times in seeds 0 and 1. Strategy A: seed 0 crashes once and intervenes 8
/// times, 4 of them checked (failing after 10, 30 and 20 steps, one surviving); seed 1 crashes
/// twice and intervenes 10 times, 2 checked (one failing after 7 steps); seed 2 neither crashes
/// nor intervenes and predates interventions.csv. Strategy B (seed 0, 3 filtered episodes) has no
/// interventions.csv at all.
fn fixture(root: &Path) {
    for seed in [0, 1] {
        RunSpec::new("sac", seed, None).outcomes(12, 6, 0).write(root);
    }
    let s0 = RunSpec::new("sac", 0, A).outcomes(12, 1, 8).write(root);
    let fail = |steps| Some((true, Some(steps)));
    let survive = Some((false, None));
    write_interventions(&s0, 1, &[fail(10), None, fail(30), None, survive, None, fail(20), None]);
    let s1 = RunSpec::new("sac", 1, A).outcomes(12, 2, 10).write(root);
    let mut checks = vec![None; 10];
    (checks[0], checks[5]) = (fail(7), survive);
    write_interventions(&s1, 2, &checks);
    RunSpec::new("sac", 2, A).outcomes(12, 0, 0).write(root);
    RunSpec::new("sac", 0, B).outcomes(12, 0, 3).write(root);
}

#[test]
fn checked_interventions_give_precision_lead_and_interventions_per_crash_avoided() {
    let root = tempfile::tempdir().unwrap();
    fixture(root.path());
    let table = table(root.path());

    // Filtered episodes, from metrics.csv, over all three seeds: 8, 10, 0.
    let a = row(&table, A.map(|a| a.0));
    let filtered = a.filtered.unwrap().stat;
    assert!(close(filtered.mean, 6.0) && close(filtered.std, (56.0f64 / 3.0).sqrt()), "{filtered:?}");
    // The bare row has no filter: no count, rather than a filter that never acted.
    assert_eq!(row(&table, None).filtered, None);
    assert!(close(row(&table, B.map(|b| b.0)).filtered.unwrap().stat.mean, 3.0));
    assert_eq!(row(&table, B.map(|b| b.0)).interventions, None);

    // Seeds 0 and 1 have interventions.csv: checked 4 and 2; precision 3/4 and 1/2; lead the
    // median of 10, 30, 20 and of 7.
    let c = a.interventions.unwrap();
    assert_eq!(c.seeds, 2);
    assert!(close(c.checked.stat.mean, 3.0) && close(c.checked.stat.std, 1.0), "{c:?}");
    let precision = c.precision.unwrap().stat;
    assert!(close(precision.mean, 0.625) && close(precision.std, 0.125), "{precision:?}");
    let lead = c.lead.unwrap().stat;
    assert!(close(lead.mean, 13.5) && close(lead.std, 6.5), "{lead:?}");
    // 9 interventions on average against 6 - 1.5 crashes avoided over the same two seeds (seed
    // 2's lone row, no crash, is not theirs to count).
    assert!(close(c.interventions.mean, 9.0) && close(c.crashes.mean, 1.5), "{c:?}");
    assert!(close(c.per_crash_avoided.unwrap(), 2.0), "{c:?}");
    assert!(
        table
            .notes
            .iter()
            .any(|n| n.contains("no interventions.csv for seed(s) 2")
                && n.contains("over the other 2 seed(s)")),
        "{:?}",
        table.notes
    );

    let md = render(&table, Format::Markdown);
    let header: String =
        md.lines().find(|l| l.starts_with("| Algorithm")).unwrap().split_whitespace().collect();
    assert!(header.contains("|Crashes|Filtered(interventions)|"), "beside the crashes: {header}");
    let a_cell = |column: &str| md_cell(&md, "| MeanDemoW5", column);
    assert_eq!(a_cell("Filtered (interventions)"), "6 ± 4.3 [0, 10]");
    assert_eq!(a_cell("Checked"), "3 ± 1.0 [2, 4]");
    assert_eq!(a_cell("Precision"), "0.62 ± 0.12 [0.50, 0.75]");
    assert_eq!(a_cell("Lead (median steps)"), "13.5 ± 6.5 [7.0, 20.0]");
    assert_eq!(a_cell("Interventions / crash avoided"), "2.0");
    for column in ["Filtered (interventions)", "Checked", "Precision", "Lead (median steps)"] {
        assert_eq!(md_cell(&md, "| -    ", column), "-", "the bare row: {md}");
    }
    assert_eq!(md_cell(&md, "| MinDemoW5", "Filtered (interventions)"), "3 ± 0.0 [3, 3]");
    assert_eq!(md_cell(&md, "| MinDemoW5", "Precision"), "-");
    assert!(md.contains("Interventions / crash avoided: the row's mean interventions"), "{md}");

    let csv = render(&table, Format::Csv);
    let names: Vec<&str> = CSV_HEADER.split(',').collect();
    let field = |line: &str, name: &str| -> String {
        line.split(',').nth(names.iter().position(|n| *n == name).unwrap()).unwrap().to_string()
    };
    let a_line = csv.lines().find(|l| l.contains(",MeanDemoW5/MeanDemoW10,")).unwrap();
    assert_eq!(field(a_line, "filtered_mean"), "6");
    assert_eq!(field(a_line, "interventions_seeds"), "2");
    assert_eq!(field(a_line, "precision_mean"), "0.625");
    assert_eq!(field(a_line, "lead_median_steps_mean"), "13.5");
    assert_eq!(field(a_line, "interventions_per_crash_avoided"), "2");
    let bare_line = csv.lines().nth(1).unwrap();
    assert_eq!(
        (field(bare_line, "filtered_mean"), field(bare_line, "checked_mean")),
        (String::new(), String::new())
    );

    let tex = render(&table, Format::Latex);
    assert!(tex.contains("& Crashes & Filtered & Precision & Lead & Int./crash avoided & \\% Time"), "{tex}");
    assert!(tex.contains("& 6$\\pm$4.3 & 0.62$\\pm$0.12 & 13.5$\\pm$6.5 & 2.0 &"), "{tex}");
}

#[test]
fn no_bare_row_or_no_fewer_crashes_leaves_interventions_per_crash_avoided_empty() {
    let root = tempfile::tempdir().unwrap();
    let run = RunSpec::new("sac", 0, A).outcomes(4, 2, 2).write(root.path());
    write_interventions(&run, 2, &[Some((true, Some(3))), None]);
    let alone = table(root.path());
    let c = row(&alone, A.map(|a| a.0)).interventions.unwrap();
    assert_eq!((c.per_crash_avoided, c.precision.unwrap().stat.mean), (None, 1.0));
    // A bare run that crashes as often: nothing avoided.
    RunSpec::new("sac", 0, None).outcomes(4, 2, 0).write(root.path());
    let same = table(root.path());
    assert_eq!(row(&same, A.map(|a| a.0)).interventions.unwrap().per_crash_avoided, None);
    let md = render(&same, Format::Markdown);
    assert_eq!(md_cell(&md, "| MeanDemoW5", "Interventions / crash avoided"), "-", "{md}");
    assert_eq!(md_cell(&md, "| MeanDemoW5", "Lead (median steps)"), "3.0 ± 0.0 [3.0, 3.0]", "{md}");
}

#[test]
fn an_interventions_file_that_disagrees_with_metrics_is_noted() {
    let root = tempfile::tempdir().unwrap();
    let run = RunSpec::new("sac", 0, A).outcomes(4, 0, 3).write(root.path());
    write_interventions(&run, 0, &[None, None]);
    let table = table(root.path());
    assert!(
        table.notes.iter().any(|n| n.contains(
            "seed 0: interventions.csv lists 2 interventions but metrics.csv has 3 filtered episodes"
        )),
        "{:?}",
        table.notes
    );
}

#[test]
fn a_malformed_interventions_file_is_an_error_naming_the_file_and_line() {
    let root = tempfile::tempdir().unwrap();
    let run = RunSpec::new("sac", 0, A).outcomes(4, 0, 2).write(root.path());
    let path = run.join("interventions.csv");
    let good = "200,1,0,100,0,1,1,12,12,-3.5,0";
    for (line, needle) in [
        ("300,2,1,100,0,yes,,,0,0,0", "column checked: \"yes\" is not 0 or 1"),
        ("300,2,1,100,0,1,2,5,5,0,0", "column would_fail: \"2\" is not 0 or 1"),
        ("300,2,1,100,0,1,1,soon,5,0,0", "column steps_to_failure: cannot read \"soon\""),
        ("300,2,1,100,0,0,1,,0,0,0", "would_fail is filled exactly when checked is 1"),
        ("300,2,1", "3 fields, the header has 11"),
    ] {
        std::fs::write(&path, format!("{INTERVENTIONS_HEADER}\n{good}\n{line}\n")).unwrap();
        let err = load_runs(&[root.path()]).unwrap_err().to_string();
        assert!(err.contains(&format!("{}:3: ", path.display())), "{err}");
        assert!(err.contains(needle), "{err}");
    }
    std::fs::write(&path, "total_steps,episode\n1,2\n").unwrap();
    let err = load_runs(&[root.path()]).unwrap_err().to_string();
    assert!(err.contains(&path.display().to_string()) && err.contains("missing column"), "{err}");
}

/// A trigger other than DTW reads no strategy, though its configuration names one: its row's Safe
/// and Unsafe cells say `-` (Markdown and CSV's safe and unsafe) while the DTW row of the same
/// strategy names it.
#[test]
fn another_trigger_names_no_dtw_strategy() {
    let root = tempfile::tempdir().unwrap();
    let dtw = RunSpec::new("sac", 0, A).outcomes(12, 1, 3).write(&root.path().join("dtw"));
    let margin = RunSpec::new("sac", 0, A).outcomes(12, 1, 3).write(&root.path().join("margin"));
    let config = margin.join("config.toml");
    let text = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, format!("{text}\n[defender.filter]\ntrigger = \"margin\"\ntask_margin = 0.4\n"))
        .unwrap();

    let table = Table::from_runs(&load_runs(&[&dtw, &margin]).unwrap().runs);
    let md = render(&table, Format::Markdown);
    assert_eq!(md_cell(&md, "margin-trigger0.4", "Safe"), "-", "{md}");
    assert_eq!(md_cell(&md, "margin-trigger0.4", "Unsafe"), "-", "{md}");
    let dtw_line = md.lines().find(|l| l.contains("MeanDemoW5") && !l.contains("trigger")).unwrap();
    assert!(dtw_line.contains("MeanDemoW10"), "{md}");
    let csv = render(&table, Format::Csv);
    // The CSV keeps the configured `strategy` (what config.toml says) beside `-` in safe, unsafe.
    let cells = |line: &str| line.split(',').map(String::from).collect::<Vec<_>>();
    let header = cells(csv.lines().next().unwrap());
    let margin_csv = cells(csv.lines().find(|l| l.contains("margin-trigger0.4")).unwrap());
    for column in ["safe", "unsafe"] {
        let k = header.iter().position(|h| h == column).unwrap();
        assert_eq!(margin_csv[k], "-", "{column}: {csv}");
    }
}
