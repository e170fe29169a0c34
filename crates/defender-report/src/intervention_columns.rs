//! What a row's interventions amount to (docs/SPEC.md, section 15): the episodes DEFENDER ended
//! beside the crashes, and, where `interventions.csv` checked them against the unfiltered
//! continuation, how many would have failed, how far ahead, and how many interventions each
//! crash avoided cost. A crash percentage alone hides the other half: a filter that ends every
//! episode never crashes.
//!
//! Everything is counted over the whole run, the learner's warm-up included: the filter acts
//! from the first step, and the crashes it is set against are counted the same way.

use defender_rl::Outcome;

use crate::interventions::InterventionSummary;
use crate::run::Run;
use crate::stats::{Estimate, Stat};

/// The columns of a row whose runs have `interventions.csv`, over the seeds that have it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterventionColumns {
    /// The seeds these columns are over (those with `interventions.csv`).
    pub seeds: usize,
    /// Interventions (rows of `interventions.csv`) per run.
    pub interventions: Stat,
    /// Crashes of the same runs, set against the bare row's for
    /// [`InterventionColumns::per_crash_avoided`].
    pub crashes: Stat,
    /// Checked interventions per run.
    pub checked: Estimate,
    /// Precision: of a run's checked interventions, the share whose continuation failed; over
    /// the seeds with a checked one (`None` when none has).
    pub precision: Option<Estimate>,
    /// Lead: a run's median steps from an intervention to its continuation's failure (the
    /// stopped action's step is 1); over the seeds with such a failure.
    pub lead: Option<Estimate>,
    /// Interventions per crash avoided: the mean interventions / (the bare row's mean crashes -
    /// [`InterventionColumns::crashes`]'s mean); `None` without a bare row of the same task,
    /// algorithm and budget, or when the row does not crash less than it. Set by the table,
    /// which knows the bare rows.
    pub per_crash_avoided: Option<f64>,
}

impl InterventionColumns {
    /// The columns of `runs` (one row's seeds); `None` when none has `interventions.csv`.
    pub fn of(runs: &[&Run]) -> Option<Self> {
        let with: Vec<(&Run, InterventionSummary)> =
            runs.iter().filter_map(|r| Some((*r, r.intervention_summary()?))).collect();
        let values = |f: &dyn Fn(&Run, &InterventionSummary) -> Option<f64>| -> Vec<f64> {
            with.iter().filter_map(|(r, s)| f(r, s)).collect()
        };
        Some(Self {
            seeds: with.len(),
            interventions: Stat::of(&values(&|_, s| Some(s.interventions as f64)))?,
            crashes: Stat::of(&values(&|r, _| Some(r.crashed() as f64)))?,
            checked: Estimate::of(&values(&|_, s| Some(s.checked as f64)))?,
            precision: Estimate::of(&values(&|_, s| s.precision())),
            lead: Estimate::of(&values(&|_, s| s.median_lead)),
            per_crash_avoided: None,
        })
    }

    /// Interventions per crash avoided against a bare row whose mean crashes are `bare_crashes`
    /// (`None`: no such row): a ratio of means rather than a mean of per-seed ratios, since a
    /// seed that happens to crash as often as its bare run would make its own ratio infinite.
    pub fn per_crash_avoided_against(&self, bare_crashes: Option<f64>) -> Option<f64> {
        let avoided = bare_crashes? - self.crashes.mean;
        (avoided > 0.0).then(|| self.interventions.mean / avoided)
    }
}

/// Filtered episodes over the run per seed, for a row with a filter (or any filtered episode):
/// `None` for a row without, whose count would read as a filter that never acted.
pub(crate) fn filtered_episodes(runs: &[&Run]) -> Option<Estimate> {
    let filters = runs.iter().any(|r| r.config.filter.is_some() || r.filtered() > 0);
    if !filters {
        return None;
    }
    Estimate::of(&runs.iter().map(|r| r.filtered() as f64).collect::<Vec<_>>())
}

/// Notes on a row's interventions, for the table's notes: seeds without `interventions.csv`
/// beside seeds with it (the columns are over the latter), and a run whose `interventions.csv`
/// disagrees with the filtered episodes of its `metrics.csv` (both count the same episodes).
pub(crate) fn notes(label: &str, runs: &[&Run]) -> Vec<String> {
    let mut notes = Vec::new();
    let without: Vec<String> =
        runs.iter().filter(|r| r.interventions.is_none()).map(|r| r.config.seed.to_string()).collect();
    if !without.is_empty() && without.len() < runs.len() {
        notes.push(format!(
            "Interventions of {label}: no interventions.csv for seed(s) {}; Checked, Precision, Lead and \
             Interventions / crash avoided are over the other {} seed(s).",
            without.join(", "),
            runs.len() - without.len()
        ));
    }
    for run in runs {
        if let Some(rows) = &run.interventions
            && rows.len() != run.filtered()
        {
            notes.push(format!(
                "{label} seed {}: interventions.csv lists {} interventions but metrics.csv has {} filtered \
                 episodes; the intervention columns read interventions.csv.",
                run.config.seed,
                rows.len(),
                run.filtered()
            ));
        }
    }
    notes
}

impl Run {
    /// Training episodes DEFENDER ended (`metrics.csv`'s outcome `filtered`): its interventions,
    /// whether or not the run wrote `interventions.csv`.
    pub fn filtered(&self) -> usize {
        self.episodes.iter().filter(|e| e.outcome == Outcome::Filtered).count()
    }

    /// The run's interventions in short, over the whole run; `None` without `interventions.csv`.
    pub fn intervention_summary(&self) -> Option<InterventionSummary> {
        self.interventions.as_deref().map(|rows| InterventionSummary::of(rows, 0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn columns(interventions: f64, crashes: f64) -> InterventionColumns {
        let one = |v: f64| Stat { mean: v, std: 0.0, n: 1 };
        InterventionColumns {
            seeds: 1,
            interventions: one(interventions),
            crashes: one(crashes),
            checked: Estimate::of(&[0.0]).unwrap(),
            precision: None,
            lead: None,
            per_crash_avoided: None,
        }
    }

    #[test]
    fn interventions_per_crash_avoided_only_when_the_row_crashes_less() {
        assert_eq!(columns(30.0, 4.0).per_crash_avoided_against(Some(10.0)), Some(5.0));
        assert_eq!(columns(30.0, 10.0).per_crash_avoided_against(Some(10.0)), None);
        assert_eq!(columns(30.0, 12.0).per_crash_avoided_against(Some(10.0)), None);
        assert_eq!(columns(30.0, 4.0).per_crash_avoided_against(None), None);
        // No intervention and fewer crashes (the learner learned): 0 per crash avoided.
        assert_eq!(columns(0.0, 4.0).per_crash_avoided_against(Some(10.0)), Some(0.0));
    }
}
