//! `interventions.csv`: every episode DEFENDER ended, whatever triggered it, and for the checked
//! ones what the unfiltered continuation did (docs/run-directory.md; docs/SPEC.md section 15).
//! Written by `defender train` for a DEFENDER run; read here for each arm's precision (the share
//! of checked interventions whose continuation failed) and lead (steps from the intervention
//! to that failure).

use std::path::Path;

use defender_rl::InterventionRecord;

use crate::csv::CsvFile;
use crate::error::{ReportError, Result};

/// The file's name in a run directory.
pub const INTERVENTIONS_FILE: &str = "interventions.csv";
/// Its header. `would_fail` is 1 or 0 for a checked intervention and empty otherwise, as is
/// `steps_to_failure` (the stopped action's step is 1) unless it failed.
pub const INTERVENTIONS_HEADER: &str = "total_steps,episode,intervention,episode_steps,episode_cost,checked,\
would_fail,steps_to_failure,continuation_steps,continuation_return,continuation_cost";

/// The row of `record` (without the newline).
pub fn intervention_row(r: &InterventionRecord) -> String {
    let opt = |v: Option<u64>| v.map(|x| x.to_string()).unwrap_or_default();
    format!(
        "{},{},{},{},{},{},{},{},{},{},{}",
        r.total_steps,
        r.episode,
        r.intervention,
        r.episode_steps,
        r.episode_cost,
        u8::from(r.checked),
        opt(r.would_fail.map(u64::from)),
        opt(r.steps_to_failure),
        r.continuation_steps,
        r.continuation_return,
        r.continuation_cost,
    )
}

/// One row, as read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterventionRow {
    /// Environment steps by the end of the episode it ended.
    pub total_steps: u64,
    /// It was checked.
    pub checked: bool,
    /// The continuation failed (checked rows only).
    pub would_fail: Option<bool>,
    /// Steps from the intervention to that failure.
    pub steps_to_failure: Option<u64>,
}

const COLUMNS: &[&str] = &["total_steps", "checked", "would_fail", "steps_to_failure"];

/// Reads `interventions.csv` at `path`.
///
/// # Errors
/// A file that does not follow the header or has a malformed value (naming file, line, column).
pub fn parse_interventions(path: &Path, text: &str) -> Result<Vec<InterventionRow>> {
    let file = CsvFile::parse(path, text, INTERVENTIONS_HEADER, COLUMNS)?;
    let mut rows = Vec::new();
    for row in file.rows() {
        // Flags are 0 or 1: any other text is a writer's mistake, not a "no".
        let flag = |k: usize, text: &str| match text {
            "0" => Ok(false),
            "1" => Ok(true),
            _ => Err(row.error(format!("column {}: {text:?} is not 0 or 1", COLUMNS[k]))),
        };
        let checked = flag(1, row.text(1))?;
        let would_fail = match row.text(2) {
            "" => None,
            t => Some(flag(2, t)?),
        };
        let steps_to_failure = match row.text(3) {
            "" => None,
            _ => Some(row.get::<u64>(3)?),
        };
        if checked != would_fail.is_some() {
            return Err(row.error("would_fail is filled exactly when checked is 1".into()));
        }
        rows.push(InterventionRow { total_steps: row.get(0)?, checked, would_fail, steps_to_failure });
    }
    Ok(rows)
}

/// The interventions of the run directory `dir`, `None` when it has no `interventions.csv` (a
/// run without DEFENDER, or one written before the file existed).
///
/// # Errors
/// The file exists but cannot be read, or [`parse_interventions`] refuses it.
pub(crate) fn load_interventions(dir: &Path) -> Result<Option<Vec<InterventionRow>>> {
    let path = dir.join(INTERVENTIONS_FILE);
    match defender_io::read_input_to_string(&path) {
        Ok(text) => parse_interventions(&path, &text).map(Some),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(ReportError::Io { path, source }),
    }
}

/// A run's interventions in short.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct InterventionSummary {
    /// Episodes DEFENDER ended.
    pub interventions: usize,
    /// Of them, checked.
    pub checked: usize,
    /// Of the checked, those whose continuation failed.
    pub would_fail: usize,
    /// The median steps from intervention to failure over those (`None` without any).
    pub median_lead: Option<f64>,
}

impl InterventionSummary {
    /// Over `rows`, those ending at or after `after` steps (the learner's warm-up left out when
    /// asked).
    pub fn of(rows: &[InterventionRow], after: u64) -> Self {
        let rows: Vec<_> = rows.iter().filter(|r| r.total_steps > after).collect();
        let checked = rows.iter().filter(|r| r.checked).count();
        let mut leads: Vec<u64> =
            rows.iter().filter(|r| r.would_fail == Some(true)).filter_map(|r| r.steps_to_failure).collect();
        leads.sort_unstable();
        let median_lead = match leads.len() {
            0 => None,
            n if n % 2 == 1 => Some(leads[n / 2] as f64),
            n => Some((leads[n / 2 - 1] + leads[n / 2]) as f64 / 2.0),
        };
        Self { interventions: rows.len(), checked, would_fail: leads.len(), median_lead }
    }

    /// The share of checked interventions whose continuation failed (`None` when none checked).
    pub fn precision(&self) -> Option<f64> {
        (self.checked > 0).then(|| self.would_fail as f64 / self.checked as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_round_trips_and_the_summary_counts_what_it_should() {
        let mut r = InterventionRecord::new(3, 7, 1200, 40, 0.0);
        let unchecked = intervention_row(&r);
        (r.checked, r.would_fail, r.steps_to_failure, r.continuation_steps) =
            (true, Some(true), Some(12), 12);
        let failed = intervention_row(&r);
        (r.would_fail, r.steps_to_failure, r.continuation_steps) = (Some(false), None, 960);
        let survived = intervention_row(&r);
        let text = format!("{INTERVENTIONS_HEADER}\n{unchecked}\n{failed}\n{survived}\n");
        let rows = parse_interventions(Path::new("interventions.csv"), &text).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!((rows[0].checked, rows[0].would_fail), (false, None));
        assert_eq!((rows[1].would_fail, rows[1].steps_to_failure), (Some(true), Some(12)));
        let s = InterventionSummary::of(&rows, 0);
        assert_eq!((s.interventions, s.checked, s.would_fail, s.median_lead), (3, 2, 1, Some(12.0)));
        assert_eq!(s.precision(), Some(0.5));
        assert_eq!(InterventionSummary::of(&rows, 1200).interventions, 0);
        let bad = format!("{INTERVENTIONS_HEADER}\n1200,7,3,40,0,0,1,,0,0,0\n");
        let e = parse_interventions(Path::new("x/interventions.csv"), &bad).unwrap_err().to_string();
        assert!(e.contains("interventions.csv") && e.contains("would_fail"), "{e}");
    }
}
