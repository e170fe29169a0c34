//! The shielded evaluation's measures: what a DEFENDER run's policy does with the filter kept, as
//! a shield would be deployed (docs/SPEC.md, section 6), beside what it does without it. Each
//! evaluation of such a run replays its episodes (the same reset seeds) with the filter, each
//! stopped at the first step the filter refuses (`eval.csv`'s `shield_*` columns); these read the
//! run's last [`LAST_EVALUATIONS`] of them, as "Last-10 eval" reads the unfiltered ones.

use crate::measures::LAST_EVALUATIONS;
use crate::run::{EvalShield, Run};
use crate::stats::Estimate;

/// The shielded columns of a row, over the seeds whose runs have shielded evaluations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShieldColumns {
    /// Shielded eval (last-10): [`Run::shield_last_evaluations`].
    pub eval: Estimate,
    /// Shielded cost (last-10): [`Run::shield_eval_cost`] (shown on the tasks with a cost limit).
    pub cost: Estimate,
    /// % Shield-ended: [`Run::shield_ended_pct`].
    pub ended_pct: Estimate,
}

impl ShieldColumns {
    /// The columns of `runs` (one row's seeds); `None` when none of them has a shielded
    /// evaluation (a bare row, or DEFENDER runs written before the shielded evaluation existed).
    pub fn of(runs: &[&Run]) -> Option<Self> {
        let values =
            |f: &dyn Fn(&Run) -> Option<f64>| -> Vec<f64> { runs.iter().filter_map(|r| f(r)).collect() };
        Some(Self {
            eval: Estimate::of(&values(&Run::shield_last_evaluations))?,
            cost: Estimate::of(&values(&Run::shield_eval_cost))?,
            ended_pct: Estimate::of(&values(&Run::shield_ended_pct))?,
        })
    }
}

impl Run {
    /// The mean of `f` over the run's last [`LAST_EVALUATIONS`] evaluations that have a shielded
    /// part (all of them when there are fewer); `None` when none has.
    fn mean_of_last(&self, f: impl Fn(&EvalShield) -> f64) -> Option<f64> {
        let shielded: Vec<EvalShield> = self.evaluations.iter().filter_map(|e| e.shield).collect();
        let last = &shielded[shielded.len().saturating_sub(LAST_EVALUATIONS)..];
        (!last.is_empty()).then(|| last.iter().map(f).sum::<f64>() / last.len() as f64)
    }

    /// Shielded eval (last-10): the mean `shield_mean_return` of the run's last 10 evaluations
    /// that have one; `None` for a run without a filter.
    pub fn shield_last_evaluations(&self) -> Option<f64> {
        self.mean_of_last(|s| s.mean_return)
    }

    /// Shielded cost (last-10): the mean `shield_mean_cost` of the same evaluations.
    pub fn shield_eval_cost(&self) -> Option<f64> {
        self.mean_of_last(|s| s.mean_cost)
    }

    /// % Shield-ended: the mean `shield_filtered` of the same evaluations x 100, the share of the
    /// shielded evaluation episodes that the filter ended.
    pub fn shield_ended_pct(&self) -> Option<f64> {
        self.mean_of_last(|s| 100.0 * s.filtered)
    }
}
