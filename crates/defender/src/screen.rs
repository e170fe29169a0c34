//! The offline screen of the filter's precision options (issue "a filter that keeps learning"):
//! recorded episodes of a bare run are replayed in order through an [`AdaptiveFilter`], as
//! training would meet them, so a variant's false alarms and caught crashes are counted before
//! any training is spent on it. Unlike the ablation (SPEC section 7) the replay is sequential:
//! the budget's margin and the own episodes that join the groups depend on the episodes before.
//!
//! What it cannot see: a filtered episode ends, so in training the agent would have gone on
//! differently; here the next recorded episode is replayed as it was.

use serde::Serialize;

use defender_rl::Outcome;

use crate::adaptive_filter::AdaptiveFilter;
use crate::demonstrations::Demonstrations;
use crate::episode_set::EpisodeSet;
use crate::error::Result;
use crate::filter_options::FilterOptions;
use crate::strategy::Strategy;
use crate::violation::UnsafeRule;

/// Counts of one replay.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct ScreenTally {
    /// Episodes replayed.
    pub episodes: usize,
    /// Of those, recorded as crashed.
    pub crashed: usize,
    /// Crashed episodes the filter ended first (caught).
    pub caught: usize,
    /// Episodes that reached the horizon but were filtered (false alarms).
    pub false_alarms: usize,
    /// Transitions of all replayed episodes.
    pub steps: usize,
    /// Transitions before each episode's first filtered step (all of an unfiltered episode's):
    /// the experience the filter leaves the agent.
    pub kept_steps: usize,
    /// Over caught crashes, the sum of `T - k`: how many steps before the crash the filter fired.
    pub lead_steps: usize,
    /// Over caught crashes, how many were caught within 10 steps of the crash.
    pub caught_late: usize,
    /// The margin after the last episode.
    pub final_margin: f64,
    /// Own episodes in the safe and unsafe groups at the end.
    pub own_safe: usize,
    /// See `own_safe`.
    pub own_unsafe: usize,
}

impl ScreenTally {
    /// Crashes caught, in % of crashed episodes.
    pub fn caught_pct(&self) -> f64 {
        pct(self.caught, self.crashed)
    }

    /// False alarms, in % of the episodes that reached the horizon.
    pub fn false_alarm_pct(&self) -> f64 {
        pct(self.false_alarms, self.episodes - self.crashed)
    }

    /// Filtered episodes, in % of all.
    pub fn filtered_pct(&self) -> f64 {
        pct(self.caught + self.false_alarms, self.episodes)
    }

    /// Crashes that remain (not caught), in % of all episodes: the % Crash replay would give.
    pub fn crash_pct(&self) -> f64 {
        pct(self.crashed - self.caught, self.episodes)
    }

    /// Experience kept, in % of the recorded transitions.
    pub fn kept_pct(&self) -> f64 {
        pct(self.kept_steps, self.steps)
    }

    /// Mean steps between the filtered step and the crash, over caught crashes.
    pub fn mean_lead(&self) -> f64 {
        if self.caught == 0 { f64::NAN } else { self.lead_steps as f64 / self.caught as f64 }
    }
}

fn pct(a: usize, b: usize) -> f64 {
    if b == 0 { f64::NAN } else { 100.0 * a as f64 / b as f64 }
}

/// Replays the first `first` episodes of `episodes` (all when `None`) in order through a filter of
/// `strategy` with `options`; `progress` is called after each episode with (done, total).
///
/// # Errors
/// Invalid options, or episodes that do not fit the demonstrations (dimensions, non-finite).
pub fn screen(
    demos: &Demonstrations,
    strategy: Strategy,
    options: FilterOptions,
    episodes: &EpisodeSet,
    first: Option<usize>,
    mut progress: impl FnMut(usize, usize),
) -> Result<ScreenTally> {
    // A recorded set of a cost task says its limit (crate::violation): its unsafe episodes end on
    // their violating step, and own episodes join by that rule, as in training.
    let rule = UnsafeRule::of_set(episodes)?;
    let mut filter = AdaptiveFilter::new(demos, strategy, options)?.with_rule(rule);
    let total = first.map_or(episodes.len(), |n| n.min(episodes.len()));
    let mut t = ScreenTally::default();
    let (mut obs, mut act, mut next) = (Vec::new(), Vec::new(), Vec::new());
    let widen = |src: &[f32], dst: &mut Vec<f64>| {
        dst.clear();
        dst.extend(src.iter().map(|&v| f64::from(v)));
    };
    for e in episodes.episodes().take(total) {
        t.episodes += 1;
        t.crashed += usize::from(e.crashed);
        t.steps += e.len();
        widen(e.observation(0), &mut obs);
        filter.begin(&obs);
        let mut filtered_at = None;
        for i in 0..e.len() {
            widen(e.observation(i), &mut obs);
            widen(e.action(i), &mut act);
            if filter.push(&obs, &act)?.filtered {
                filtered_at = Some(i);
                break;
            }
            widen(e.observation(i + 1), &mut next);
            filter.executed(&act, f64::from(e.rew[i]), &next)?;
            if e.crashed && i + 1 == e.len() {
                filter.violated();
            }
        }
        let outcome = match filtered_at {
            Some(k) => {
                t.kept_steps += k;
                if e.crashed {
                    t.caught += 1;
                    t.lead_steps += e.len() - k;
                    t.caught_late += usize::from(e.len() - k <= 10);
                } else {
                    t.false_alarms += 1;
                }
                Outcome::Filtered
            }
            None => {
                t.kept_steps += e.len();
                if e.crashed { Outcome::Crashed } else { Outcome::Truncated }
            }
        };
        filter.end(outcome)?;
        progress(t.episodes, total);
    }
    t.final_margin = filter.margin();
    (t.own_safe, t.own_unsafe) = filter.own_counts();
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::CostOptions;
    use crate::episode_set::Meta;
    use crate::filter_options::OwnEpisodes;
    use crate::strategy::Mode;

    /// Demonstrations on a line: safe ones stay at 0 for the horizon of 4 steps, unsafe ones run
    /// to 10.
    fn demos() -> Demonstrations {
        let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        set.push_episode(&[0.0; 5], &[0.0; 4], &[1.0; 4], false).unwrap();
        set.push_episode(&[0.0, 2.0, 4.0, 6.0, 8.0, 10.0], &[2.0; 5], &[0.0; 5], true).unwrap();
        Demonstrations::new(&set, Mode::State, CostOptions::default()).unwrap()
    }

    #[test]
    fn counts_caught_crashes_false_alarms_and_kept_steps() {
        let mut rec = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        // A crash running right (caught), a quiet episode (kept whole), a quiet episode that
        // drifts right at its end (a false alarm: it reached the horizon).
        rec.push_episode(&[0.0, 3.0, 6.0, 9.0, 12.0], &[3.0; 4], &[0.0; 4], true).unwrap();
        rec.push_episode(&[0.0; 5], &[0.0; 4], &[1.0; 4], false).unwrap();
        rec.push_episode(&[0.0, 0.0, 10.0, 10.0, 10.0], &[0.0; 4], &[1.0; 4], false).unwrap();
        let s: Strategy = "MinBothW5/MinBothW5".parse().unwrap();
        let t = screen(&demos(), s, FilterOptions::default(), &rec, None, |_, _| {}).unwrap();
        assert_eq!((t.episodes, t.crashed, t.caught, t.false_alarms, t.steps), (3, 1, 1, 1, 12));
        assert!(t.kept_steps < 12 && t.kept_steps >= 4, "{t:?}");
        assert_eq!(t.crash_pct(), 0.0);
        let only_first = screen(&demos(), s, FilterOptions::default(), &rec, Some(1), |_, _| {}).unwrap();
        assert_eq!(only_first.episodes, 1);
        // A wide margin catches less.
        let wide = FilterOptions { margin: 0.999, ..Default::default() };
        let w = screen(&demos(), s, wide, &rec, None, |_, _| {}).unwrap();
        assert!(w.caught + w.false_alarms <= t.caught + t.false_alarms);
        // Own episodes: the quiet one joins the safe group.
        let own = FilterOptions { own_episodes: Some(OwnEpisodes { keep: 5 }), ..Default::default() };
        let o = screen(&demos(), s, own, &rec, None, |_, _| {}).unwrap();
        assert!(o.own_safe >= 1, "{o:?}");
    }
}
