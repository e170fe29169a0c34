//! How the renderers write a cell: numbers rounded as the paper rounds them, mean ± std, the
//! bootstrap interval, and the sections (trajectory modes) a report is split into.

use defender::Mode;

use crate::stats::{Estimate, Stat};
use crate::table::{Row, Table};

/// How a mean is printed: the paper prints Acc Reward and % Crash means without decimals and
/// their std with one; the Markdown table keeps one decimal on % Crash, which small runs need.
pub(crate) fn number(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    // `-0` and `-0.0` read as noise.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.replace('-', "")
    } else {
        text
    }
}

/// `mean{sep}std`, the std with one decimal.
pub(crate) fn pm(stat: &Stat, decimals: usize, sep: &str) -> String {
    pm_to(stat, decimals, 1, sep)
}

/// [`pm`] with the std to `std_decimals`: a value well below 1 (the cost rate, ~0.05) has a std
/// that one decimal rounds to 0.
pub(crate) fn pm_to(stat: &Stat, decimals: usize, std_decimals: usize, sep: &str) -> String {
    format!("{}{sep}{}", number(stat.mean, decimals), number(stat.std, std_decimals))
}

/// `mean ± std [lo, hi]`: [`pm`] and the 95% bootstrap interval, its bounds with the mean's
/// decimals.
pub(crate) fn pm_ci(estimate: &Estimate, decimals: usize) -> String {
    pm_ci_to(estimate, decimals, 1)
}

/// [`pm_ci`] with the std to `std_decimals` ([`pm_to`]).
pub(crate) fn pm_ci_to(estimate: &Estimate, decimals: usize, std_decimals: usize) -> String {
    format!(
        "{} [{}, {}]",
        pm_to(&estimate.stat, decimals, std_decimals, " ± "),
        number(estimate.ci.lo, decimals),
        number(estimate.ci.hi, decimals)
    )
}

/// [`pm_ci`], or `-` for a value the row does not have.
pub(crate) fn pm_ci_or_dash(estimate: Option<&Estimate>, decimals: usize) -> String {
    estimate.map_or_else(|| "-".to_string(), |e| pm_ci(e, decimals))
}

/// % Time's mean, or `-` without a bare run to compare with.
pub(crate) fn time(row: &Row) -> String {
    row.time_pct.map_or_else(|| "-".to_string(), |t| number(t.mean, 0))
}

pub(crate) fn mode_title(mode: Option<Mode>) -> &'static str {
    match mode {
        Some(Mode::State) => "state trajectories (as the paper's Table 1)",
        Some(Mode::StateAction) => "state-action trajectories (as the paper's Table 2)",
        None => "bare algorithms",
    }
}

/// The sections of a report: each trajectory mode (or just the bare rows when there is no
/// DEFENDER run), each with all bare rows.
pub(crate) fn sections(table: &Table) -> Vec<Option<Mode>> {
    let modes = table.modes();
    if modes.is_empty() { vec![None] } else { modes.into_iter().map(Some).collect() }
}

/// The number of demonstrations per group of a row, `-` for the bare algorithm.
pub(crate) fn demos_text(row: &Row) -> String {
    match &row.filter {
        None => "-".into(),
        Some(f) => f.num_demos.map_or_else(|| "?".into(), |n| n.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bootstrap::Interval;

    #[test]
    fn numbers_round_like_the_paper() {
        assert_eq!(number(3474.4, 0), "3474");
        assert_eq!(number(-0.3, 0), "0");
        assert_eq!(number(-0.04, 1), "0.0");
        assert_eq!(number(-4.0, 0), "-4");
        let s = Stat { mean: 63.96, std: 6.04, n: 3 };
        assert_eq!(pm(&s, 0, "$\\pm$"), "64$\\pm$6.0");
        let e = Estimate { stat: s, ci: Interval { lo: 55.04, hi: 70.5 } };
        assert_eq!(pm_ci(&e, 1), "64.0 ± 6.0 [55.0, 70.5]");
        assert_eq!(pm_ci_or_dash(None, 1), "-");
        let rate =
            Estimate { stat: Stat { mean: 0.0524, std: 0.0131, n: 3 }, ci: Interval { lo: 0.04, hi: 0.07 } };
        assert_eq!(pm_ci_to(&rate, 3, 3), "0.052 ± 0.013 [0.040, 0.070]");
    }
}
