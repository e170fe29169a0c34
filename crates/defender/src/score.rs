//! Ablation scores (SPEC section 7) and their ranking; the CSV of SPEC section 9 is
//! crate::ablation_csv.

use crate::error::{DefenderError, Result};
use crate::method::Method;
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A row of `score` for strategy `s` (also the CSV tests' rows, crate::ablation_csv).
    pub(crate) fn row(s: &str, score: f64) -> AblationRow {
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
}
