//! A run's violations counted from its episodes (`metrics.csv`), and their running sums over
//! environment steps: the curves of `defender report --plots`. Apart from [`Violations`], which
//! `summary.json` holds, so that the summary's type does not depend on the run's episodes.

use crate::run::{EpisodeRow, Run};
use crate::violations::Violations;

impl Run {
    /// The run's violations, from `metrics.csv` (whatever `summary.json` holds: those written
    /// before the measures existed hold none) and the summary's step counts.
    pub fn violations(&self) -> Violations {
        let crashes = self.episodes.iter().filter(|e| e.outcome == defender_rl::Outcome::Crashed).count();
        let cost = self.episodes.iter().map(|e| e.cost).sum();
        Violations::new(crashes as u64, cost, self.summary.steps, self.summary.filtered_steps)
    }

    /// `(environment steps, crashes so far)` at the end of each training episode: the cumulative
    /// crash curve (counted as `Run::cumulative` says).
    pub fn cumulative_crashes(&self) -> Vec<(u64, u64)> {
        self.cumulative(|e| u64::from(e.outcome == defender_rl::Outcome::Crashed))
    }

    /// `(environment steps, cost so far)` at the end of each training episode: the cumulative
    /// cost curve of a per-step cost task (counted as `Run::cumulative` says).
    pub fn cumulative_cost(&self) -> Vec<(u64, f64)> {
        self.cumulative(|e| e.cost)
    }

    /// `(environment steps, running sum)` at the end of each training episode, the sum adding
    /// `of` of every episode so far. Filtered steps do not count as environment steps; a run's episodes do not say
    /// which of their steps were filtered, but a filtered episode ends at its one filtered step,
    /// so each filtered episode up to and including this one takes one step off.
    fn cumulative<T: Copy + Default + std::ops::AddAssign>(
        &self,
        of: impl Fn(&EpisodeRow) -> T,
    ) -> Vec<(u64, T)> {
        let (mut sum, mut filtered) = (T::default(), 0u64);
        self.episodes
            .iter()
            .map(|e| {
                sum += of(e);
                filtered += u64::from(e.outcome == defender_rl::Outcome::Filtered);
                (e.total_steps.saturating_sub(filtered), sum)
            })
            .collect()
    }
}
