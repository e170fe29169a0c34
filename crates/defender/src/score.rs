//! Ablation scores (SPEC section 7), their ranking, and the CSV of SPEC section 9.

use std::io::Write;
use std::path::Path;

use crate::atomic::{io_at, write_atomic};
use crate::error::{DefenderError, Result};
use crate::method::Method;
use crate::scoring::Scoring;
use crate::strategy::{Mode, Strategy};

/// One row of the ablation's output (SPEC section 9).
#[derive(Debug, Clone, PartialEq)]
pub struct AblationRow {
    /// 1-based rank: score highest first, ties by strategy name.
    pub rank: usize,
    /// The strategy.
    pub strategy: Strategy,
    /// The trajectory mode.
    pub mode: Mode,
    /// `mean_e(ratio_e)`: `(k + 1) / T_e` for an episode filtered at step k, else 1. Under the
    /// authors' scoring ([`crate::Scoring::Authors`]), their `mean(k / T_e)`.
    pub mean_ratio: f64,
    /// `count(safe_e) / |E|`: episodes that did not crash, or crashed and were filtered. Under
    /// the authors' scoring, the share of the episodes shorter than the horizon that were
    /// filtered (1 when none is).
    pub safe_rate: f64,
    /// `mean_ratio * safe_rate`.
    pub score: f64,
}

impl AblationRow {
    /// The safe group's method.
    pub fn safe_method(&self) -> Method {
        self.strategy.safe
    }

    /// The unsafe group's method.
    pub fn unsafe_method(&self) -> Method {
        self.strategy.unsafe_
    }
}

/// Running sums of one strategy over recorded episodes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StrategyTally {
    /// Sum of `ratio_e`.
    pub ratio_sum: f64,
    /// Episodes counted as safe.
    pub safe: usize,
    /// Episodes.
    pub episodes: usize,
}

impl StrategyTally {
    /// Adds one recorded episode of `len` transitions that `crashed` (or not), first filtered at
    /// step `first_filtered` (if any).
    pub fn add(&mut self, len: usize, crashed: bool, first_filtered: Option<usize>) {
        self.ratio_sum += match first_filtered {
            Some(k) => (k + 1) as f64 / len as f64,
            None => 1.0,
        };
        self.safe += usize::from(!crashed || first_filtered.is_some());
        self.episodes += 1;
    }

    /// The unranked row (rank 0) of `strategy`.
    pub fn row(&self, strategy: Strategy, mode: Mode) -> AblationRow {
        let e = self.episodes.max(1) as f64;
        let mean_ratio = self.ratio_sum / e;
        let safe_rate = self.safe as f64 / e;
        AblationRow { rank: 0, strategy, mode, mean_ratio, safe_rate, score: mean_ratio * safe_rate }
    }
}

/// Sorts rows by score, highest first, ties by strategy name (then mode), and numbers them 1, 2, ...
pub fn rank(mut rows: Vec<AblationRow>) -> Vec<AblationRow> {
    rows.sort_by(|a, b| {
        b.score
            .total_cmp(&a.score)
            .then_with(|| a.strategy.to_string().cmp(&b.strategy.to_string()))
            .then_with(|| a.mode.name().cmp(b.mode.name()))
    });
    for (i, r) in rows.iter_mut().enumerate() {
        r.rank = i + 1;
    }
    rows
}

/// Ranks strategies over several tasks by their mean score (SPEC section 7). Each task's rows
/// must hold the same (strategy, mode) pairs; the result's `mean_ratio`, `safe_rate` and `score`
/// are the means over tasks.
///
/// # Errors
/// No task, or tasks whose rows do not cover the same strategies and modes.
pub fn rank_tasks(tasks: &[Vec<AblationRow>]) -> Result<Vec<AblationRow>> {
    let first = tasks
        .first()
        .ok_or_else(|| DefenderError::Config("ranking over tasks needs at least one task".into()))?;
    let key = |r: &AblationRow| (r.strategy, r.mode);
    let mut rows: Vec<AblationRow> = first.clone();
    rows.sort_by_key(key);
    for (t, task) in tasks.iter().enumerate().skip(1) {
        let mut other = task.clone();
        other.sort_by_key(key);
        if other.len() != rows.len() || other.iter().zip(&rows).any(|(a, b)| key(a) != key(b)) {
            return Err(DefenderError::Mismatch {
                what: format!("strategies of task {t} vs task 0 (ranking over tasks)"),
                expected: format!("the same {} (strategy, mode) rows", rows.len()),
                got: format!("{} rows, not the same set", other.len()),
            });
        }
        for (r, o) in rows.iter_mut().zip(&other) {
            r.mean_ratio += o.mean_ratio;
            r.safe_rate += o.safe_rate;
            r.score += o.score;
        }
    }
    let n = tasks.len() as f64;
    for r in &mut rows {
        r.mean_ratio /= n;
        r.safe_rate /= n;
        r.score /= n;
    }
    Ok(rank(rows))
}

/// The CSV header of SPEC section 9.
pub const CSV_HEADER: &str = "rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score";

/// Writes rows as the CSV of SPEC section 9, atomically. Numbers are written in Rust's shortest
/// round-trip form, so [`read_csv`] gives them back exactly.
///
/// # Errors
/// An I/O error.
pub fn write_csv(path: impl AsRef<Path>, rows: &[AblationRow]) -> Result<()> {
    write_csv_scored(path, rows, Scoring::Spec)
}

/// [`write_csv`] for rows `scoring` computed: SPEC's are written as [`write_csv`] writes them;
/// any other gets a last column, `scoring`, naming it on every row (SPEC section 9 allows
/// columns after its own), so that a file says what its scores mean.
///
/// # Errors
/// An I/O error.
pub fn write_csv_scored(path: impl AsRef<Path>, rows: &[AblationRow], scoring: Scoring) -> Result<()> {
    let path = path.as_ref();
    let extra = match scoring {
        Scoring::Spec => String::new(),
        other => format!(",{}", other.name()),
    };
    write_atomic(path, |w| {
        let header_extra = if extra.is_empty() { "" } else { ",scoring" };
        writeln!(w, "{CSV_HEADER}{header_extra}").map_err(io_at(path))?;
        for r in rows {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{}{extra}",
                r.rank,
                r.strategy,
                r.strategy.safe,
                r.strategy.unsafe_,
                r.mode,
                r.mean_ratio,
                r.safe_rate,
                r.score
            )
            .map_err(io_at(path))?;
        }
        Ok(())
    })
}

/// The scoring a CSV of [`write_csv_scored`] names in its `scoring` column (`spec` when it has
/// none, as [`write_csv`] writes SPEC's).
///
/// # Errors
/// An I/O error, or a file without the header of SPEC section 9.
pub fn csv_scoring(path: impl AsRef<Path>) -> Result<String> {
    let path = path.as_ref();
    let text = defender_io::read_input_to_string(path).map_err(io_at(path))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if !header.starts_with(CSV_HEADER) {
        return Err(DefenderError::Format {
            path: path.to_owned(),
            what: format!("line 1: expected the header `{CSV_HEADER}`, got {header:?}"),
        });
    }
    let Some(column) = header.split(',').position(|c| c == "scoring") else { return Ok("spec".into()) };
    Ok(lines.next().and_then(|l| l.split(',').nth(column)).unwrap_or("spec").to_string())
}

/// Reads a CSV written by [`write_csv`] (extra trailing columns are ignored).
///
/// # Errors
/// An I/O error, a wrong header, or a malformed row (naming the file and line).
pub fn read_csv(path: impl AsRef<Path>) -> Result<Vec<AblationRow>> {
    let path = path.as_ref();
    let text = defender_io::read_input_to_string(path).map_err(io_at(path))?;
    let mut lines = text.lines();
    let format = |line: usize, what: String| DefenderError::Format {
        path: path.to_owned(),
        what: format!("line {line}: {what}"),
    };
    match lines.next() {
        Some(h) if h.starts_with(CSV_HEADER) => {}
        other => return Err(format(1, format!("expected the header `{CSV_HEADER}`, got {other:?}"))),
    }
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let n = i + 2;
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 8 {
            return Err(format(n, format!("expected 8 columns, got {}", f.len())));
        }
        let num =
            |k: usize| f[k].parse::<f64>().map_err(|e| format(n, format!("column {k} `{}`: {e}", f[k])));
        let strategy: Strategy = f[1].parse().map_err(|e| format(n, format!("{e}")))?;
        if f[2] != strategy.safe.to_string() || f[3] != strategy.unsafe_.to_string() {
            return Err(format(
                n,
                format!("safe_method/unsafe_method `{},{}` do not match strategy `{strategy}`", f[2], f[3]),
            ));
        }
        rows.push(AblationRow {
            rank: f[0].parse().map_err(|e| format(n, format!("rank `{}`: {e}", f[0])))?,
            strategy,
            mode: f[4].parse().map_err(|e| format(n, format!("{e}")))?,
            mean_ratio: num(5)?,
            safe_rate: num(6)?,
            score: num(7)?,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(s: &str, score: f64) -> AblationRow {
        AblationRow {
            rank: 0,
            strategy: s.parse().unwrap(),
            mode: Mode::State,
            mean_ratio: score,
            safe_rate: 1.0,
            score,
        }
    }

    #[test]
    fn tallies_follow_the_spec_formula() {
        let mut t = StrategyTally::default();
        t.add(10, true, Some(4)); // filtered at k = 4: ratio 0.5, a prevented crash
        t.add(10, true, None); // a crash not prevented: ratio 1, unsafe
        t.add(5, false, None); // safe, unfiltered
        t.add(4, false, Some(0)); // safe, filtered at once: ratio 0.25
        let r = t.row("MinBoth/MinBoth".parse().unwrap(), Mode::State);
        assert_eq!(r.mean_ratio, (0.5 + 1.0 + 1.0 + 0.25) / 4.0);
        assert_eq!(r.safe_rate, 0.75);
        assert_eq!(r.score, r.mean_ratio * 0.75);
    }

    #[test]
    fn ranking_is_by_score_then_name() {
        let rows = rank(vec![
            row("MinBoth/MinBoth", 0.5),
            row("MaxBoth/MinBoth", 0.9),
            row("MeanBoth/MinBoth", 0.5),
        ]);
        let names: Vec<String> = rows.iter().map(|r| format!("{} {}", r.rank, r.strategy)).collect();
        assert_eq!(names, ["1 MaxBoth/MinBoth", "2 MeanBoth/MinBoth", "3 MinBoth/MinBoth"]);
    }

    #[test]
    fn multi_task_ranking_uses_the_mean_score() {
        let a = vec![row("MinBoth/MinBoth", 1.0), row("MaxBoth/MaxBoth", 0.0)];
        let b = vec![row("MaxBoth/MaxBoth", 0.8), row("MinBoth/MinBoth", 0.2)];
        let r = rank_tasks(&[a.clone(), b]).unwrap();
        assert_eq!(r[0].strategy.to_string(), "MinBoth/MinBoth");
        assert_eq!(r[0].score, 0.6);
        assert_eq!(r[1].score, 0.4);
        assert!(rank_tasks(&[a, vec![row("MinBoth/MinBoth", 1.0)]]).is_err());
        assert!(rank_tasks(&[]).is_err());
    }

    #[test]
    fn csv_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ablation.csv");
        let rows = rank(vec![row("MeanDemoW5/MeanDemoW10", 0.1 + 0.2), row("MinBoth/MinTrajW10", 1.0 / 3.0)]);
        write_csv(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score\n")
        );
        assert!(text.contains("\n1,MinBoth/MinTrajW10,MinBoth,MinTrajW10,state,"), "{text}");
        assert_eq!(read_csv(&path).unwrap(), rows);
        assert_eq!(csv_scoring(&path).unwrap(), "spec");
        let authors = dir.path().join("authors.csv");
        write_csv_scored(&authors, &rows, Scoring::Authors { horizon: 1000 }).unwrap();
        let text = std::fs::read_to_string(&authors).unwrap();
        assert!(text.starts_with(&format!("{CSV_HEADER},scoring\n")), "{text}");
        assert!(text.lines().skip(1).all(|l| l.ends_with(",authors")), "{text}");
        assert_eq!(read_csv(&authors).unwrap(), rows);
        assert_eq!(csv_scoring(&authors).unwrap(), "authors");
        std::fs::write(&path, "bad header\n").unwrap();
        assert!(read_csv(&path).unwrap_err().to_string().contains("line 1"));
    }
}
