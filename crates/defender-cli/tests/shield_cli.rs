//! Evaluation with and without the filter, through the binary: a DEFENDER run's `eval.csv` has the
//! shielded evaluation's three columns filled on every row (the same episodes with the filter
//! kept), a bare run's has them empty, and `defender report` shows them beside the unfiltered
//! evaluation.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

mod common;

use common::{ok, s};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

fn shipped_demos() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"))
}

/// `eval.csv` as its header and rows, each row's fields by column name.
fn eval_rows(dir: &Path) -> (String, Vec<std::collections::HashMap<String, String>>) {
    let text = std::fs::read_to_string(dir.join("eval.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let names: Vec<&str> = header.split(',').collect();
    let rows = lines
        .map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            assert_eq!(fields.len(), names.len(), "{l}");
            names.iter().zip(fields).map(|(n, f)| (n.to_string(), f.to_string())).collect()
        })
        .collect();
    (header, rows)
}

#[test]
fn a_defender_runs_evaluations_are_shielded_too_and_the_report_shows_both() {
    let tmp = tempfile::tempdir().unwrap();
    let runs = tmp.path().join("runs");
    let (bare, def) = (runs.join("bare"), runs.join("defender"));
    let common = ["train", "--env", ENV_ID, "--steps", "400", "--eval-freq", "100", "--seed", "1"];
    ok(&[&common[..], &["--out", s(&bare)]].concat());
    let demos = shipped_demos();
    let filter = ["--strategy", "MeanDemoW5/MeanDemoW10", "--demos", s(&demos), "--num-demos", "5"];
    ok(&[&common[..], &filter[..], &["--out", s(&def)]].concat());

    let shield_columns = ["shield_mean_return", "shield_mean_cost", "shield_filtered"];
    let (header, rows) = eval_rows(&bare);
    assert_eq!(header, defender_report::EVAL_HEADER);
    assert_eq!(rows.len(), 4, "at 100, 200 and 300 steps, and the final one");
    for row in &rows {
        assert!(shield_columns.iter().all(|c| row[*c].is_empty()), "a bare run has no filter: {row:?}");
    }

    let (header, rows) = eval_rows(&def);
    assert_eq!(header, defender_report::EVAL_HEADER);
    assert_eq!(rows.len(), 4);
    for row in &rows {
        let value = |c: &str| -> f64 { row[c].parse().unwrap_or_else(|_| panic!("{c}: {row:?}")) };
        let filtered = value("shield_filtered");
        assert!((0.0..=1.0).contains(&filtered), "{row:?}");
        let episodes = value("episodes");
        assert_eq!((filtered * episodes).round(), filtered * episodes, "a share of {episodes} episodes");
        // A crash costs 1 on this task: a mean episode cost is at most 1.
        assert!((0.0..=1.0).contains(&value("shield_mean_cost")), "{row:?}");
        assert!(value("shield_mean_return").is_finite());
        if filtered == 0.0 {
            // The filter ended none: the same episodes (the same seeds), the same numbers.
            assert_eq!(row["shield_mean_return"], row["mean_return"], "{row:?}");
            assert_eq!(row["shield_mean_cost"], row["mean_cost"], "{row:?}");
        }
    }

    let report = ok(&["report", s(&runs)]);
    let header = report.lines().find(|l| l.starts_with("| Algorithm")).expect("a table");
    let names: Vec<&str> = header.split('|').map(str::trim).collect();
    let last10 = names.iter().position(|n| *n == "Last-10 eval").unwrap();
    assert_eq!(names[last10 + 1], "Shielded eval (last-10)", "{report}");
    assert_eq!(names[last10 + 2], "% Shield-ended", "{report}");
    let bare_row =
        report.lines().find(|l| l.starts_with("| SAC") && l.contains("| -")).expect("the bare row");
    let cells: Vec<&str> = bare_row.split('|').map(str::trim).collect();
    assert_eq!((cells[last10 + 1], cells[last10 + 2]), ("-", "-"), "{bare_row}");
    let csv = ok(&["report", s(&runs), "--format", "csv"]);
    let columns: Vec<&str> = defender_report::CSV_HEADER.split(',').collect();
    let filled = |line: &str| {
        let fields: Vec<&str> = line.split(',').collect();
        !fields[columns.iter().position(|c| *c == "shield_eval_last10_mean").unwrap()].is_empty()
    };
    let lines: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(lines.iter().filter(|l| filled(l)).count(), 1, "the DEFENDER row alone:\n{csv}");
}
