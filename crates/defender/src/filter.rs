//! The online filter (SPEC section 4): at every step, align the trajectory so far with both groups
//! of demonstrations and decide whether the proposed action is executed.

use crate::cost::Ties;
use crate::cost_stream::CostStream;
use crate::demonstrations::Demonstrations;
use crate::error::{DefenderError, Result};
use crate::strategy::{Mode, Strategy};

/// The filter's verdict on one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The step is filtered: `Safe(tau) >= Unsafe(tau)` (ties filter; with [`Ties::Execute`],
    /// `Safe(tau) > Unsafe(tau)`).
    pub filtered: bool,
    /// `Safe(tau)`: the safe method over the safe group.
    pub safe_cost: f64,
    /// `Unsafe(tau)`: the unsafe method over the unsafe group.
    pub unsafe_cost: f64,
}

impl Decision {
    /// The decision rule of SPEC section 4: execute iff `safe < unsafe`; otherwise (ties, and any
    /// NaN) filter.
    pub fn new(safe_cost: f64, unsafe_cost: f64) -> Self {
        Self::with_ties(safe_cost, unsafe_cost, Ties::Filter)
    }

    /// The decision under a tie rule: with [`Ties::Execute`] (the authors' code) an equal cost
    /// executes and only `safe > unsafe` filters; unordered (NaN) costs filter under both rules.
    pub fn with_ties(safe_cost: f64, unsafe_cost: f64, ties: Ties) -> Self {
        Self::with_margin(safe_cost, unsafe_cost, ties, 0.0)
    }

    /// The decision with a margin `m` (`[defender.filter] margin`): executed iff
    /// `(1 - m) * Safe < Unsafe` (`<=` with [`Ties::Execute`]), so the trajectory must be clearly
    /// closer to the unsafe group to be filtered; `m = 0` is the rule above.
    pub fn with_margin(safe_cost: f64, unsafe_cost: f64, ties: Ties, margin: f64) -> Self {
        use std::cmp::Ordering::{Equal, Less};
        let threshold = if margin == 0.0 { safe_cost } else { (1.0 - margin) * safe_cost };
        let filtered = !matches!(
            (threshold.partial_cmp(&unsafe_cost), ties),
            (Some(Less), _) | (Some(Equal), Ties::Execute)
        );
        Self { filtered, safe_cost, unsafe_cost }
    }
}

/// The online DEFENDER filter for one strategy.
///
/// Each [`Filter::push`] appends the step's element (`s_t`, or `concat(s_t, a_t)`) to the
/// trajectory and updates the incremental DTW state of the one window each group needs, so the
/// cost of a step does not grow with the episode's length (except for `Equal`, which cannot be
/// incremental). Call [`Filter::reset`] at the start of every episode. No allocation per step
/// once the first episode of the longest length has been seen.
#[derive(Debug, Clone)]
pub struct Filter {
    demos: Demonstrations,
    strategy: Strategy,
    safe: CostStream,
    unsafe_: CostStream,
    element: Vec<f32>,
    act: Vec<f32>,
    margin: f64,
}

impl Filter {
    /// A filter for `strategy` over the prepared demonstrations.
    ///
    /// # Errors
    /// A DTW error for an invalid view (cannot happen for the SPEC's windows).
    pub fn new(demos: &Demonstrations, strategy: Strategy) -> Result<Self> {
        let safe = demos.cost_stream(false, &[strategy.safe.window])?;
        let unsafe_ = demos.cost_stream(true, &[strategy.unsafe_.window])?;
        Ok(Self {
            demos: demos.clone(),
            strategy,
            safe,
            unsafe_,
            element: Vec::with_capacity(demos.element_dim()),
            act: Vec::with_capacity(demos.act_dim()),
            margin: 0.0,
        })
    }

    /// The strategy.
    pub fn strategy(&self) -> Strategy {
        self.strategy
    }

    /// The decision margin in use (0: SPEC's rule; see [`Decision::with_margin`]).
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// Sets the decision margin (validated by the caller: `[0, 1)`).
    pub fn set_margin(&mut self, margin: f64) {
        self.margin = margin;
    }

    /// The trajectory mode.
    pub fn mode(&self) -> Mode {
        self.demos.mode()
    }

    /// The demonstrations.
    pub fn demonstrations(&self) -> &Demonstrations {
        &self.demos
    }

    /// Length of the current trajectory (steps pushed since the last reset).
    pub fn len(&self) -> usize {
        self.safe.len()
    }

    /// True at the start of an episode.
    pub fn is_empty(&self) -> bool {
        self.safe.is_empty()
    }

    /// Starts a new episode (forgets the trajectory, keeps every buffer).
    pub fn reset(&mut self) {
        self.safe.reset();
        self.unsafe_.reset();
    }

    /// Step `t`: the agent observed `obs = s_t` and proposes `action = a_t`. Appends `e_t` to the
    /// trajectory and decides (SPEC section 4). The action is checked in both modes.
    ///
    /// # Errors
    /// Wrong lengths ([`DefenderError::Mismatch`]) or non-finite values (a DTW error); the
    /// trajectory is unchanged then.
    pub fn push(&mut self, obs: &[f64], action: &[f64]) -> Result<Decision> {
        self.check_lengths(obs.len(), action.len())?;
        self.act.clear();
        self.act.extend(action.iter().map(|&a| a as f32));
        self.demos.element_into(obs.iter().map(|&o| o as f32), &self.act, &mut self.element);
        self.push_prepared()
    }

    /// As [`Filter::push`] for f32 data (recorded episodes).
    ///
    /// # Errors
    /// As [`Filter::push`].
    pub fn push_f32(&mut self, obs: &[f32], action: &[f32]) -> Result<Decision> {
        self.check_lengths(obs.len(), action.len())?;
        self.demos.element_into(obs.iter().copied(), action, &mut self.element);
        self.push_prepared()
    }

    fn check_lengths(&self, obs: usize, act: usize) -> Result<()> {
        for (what, got, expected) in
            [("observation", obs, self.demos.obs_dim()), ("action", act, self.demos.act_dim())]
        {
            if got != expected {
                return Err(DefenderError::Mismatch {
                    what: format!("{what} pushed to the filter (its length)"),
                    expected: expected.to_string(),
                    got: got.to_string(),
                });
            }
        }
        Ok(())
    }

    fn push_prepared(&mut self) -> Result<Decision> {
        // Check before the first stream moves, so that an error leaves both untouched.
        if let Some(i) = self.element.iter().position(|v| !v.is_finite()) {
            return Err(defender_dtw::DtwError::NonFinite {
                name: "trajectory element".into(),
                index: i,
                value: self.element[i],
            }
            .into());
        }
        self.safe.push(&self.element)?;
        self.unsafe_.push(&self.element)?;
        let safe = self.strategy.safe.aggregation.apply(self.safe.costs(0));
        let unsafe_ = self.strategy.unsafe_.aggregation.apply(self.unsafe_.costs(0));
        Ok(Decision::with_margin(safe, unsafe_, self.demos.options().ties, self.margin))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demonstrations::CostOptions;
    use crate::episode_set::{EpisodeSet, Meta};

    /// Safe demonstration [0, 0, 0], unsafe [10, 10] (dimension 1).
    fn demos(mode: Mode) -> Demonstrations {
        let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        set.push_episode(&[0., 0., 0.], &[0., 0.], &[1., 1.], false).unwrap();
        set.push_episode(&[10., 10.], &[0.], &[-1.], true).unwrap();
        Demonstrations::new(&set, mode, CostOptions::default()).unwrap()
    }

    #[test]
    fn ties_filter() {
        assert!(Decision::new(1.0, 1.0).filtered);
        assert!(Decision::new(2.0, 1.0).filtered);
        assert!(!Decision::new(0.5, 1.0).filtered);
        assert!(Decision::new(f64::NAN, 1.0).filtered);
        assert!(!Decision::with_ties(1.0, 1.0, Ties::Execute).filtered);
        assert!(Decision::with_ties(1.5, 1.0, Ties::Execute).filtered);
        assert!(Decision::with_ties(f64::NAN, 1.0, Ties::Execute).filtered);
        // A margin: filtered iff unsafe <= (1 - m) * safe.
        assert!(!Decision::with_margin(1.0, 0.9, Ties::Filter, 0.2).filtered);
        assert!(Decision::with_margin(1.0, 0.8, Ties::Filter, 0.2).filtered);
        assert!(!Decision::with_margin(1.0, 0.8, Ties::Execute, 0.2).filtered);
        assert!(Decision::with_margin(1.0, 0.7, Ties::Execute, 0.2).filtered);
        assert!(Decision::with_margin(1.0, f64::NAN, Ties::Execute, 0.2).filtered);
    }

    #[test]
    fn filters_when_closer_to_the_unsafe_group() {
        let s: Strategy = "MinBothW5/MinBothW5".parse().unwrap();
        let mut f = Filter::new(&demos(Mode::State), s).unwrap();
        let d = f.push(&[1.0], &[0.0]).unwrap();
        // BothW5 of [1] vs [0,0,0] = 3 * |1 - 0| (the path crosses all of y); vs [10,10] = 2 * 9.
        assert_eq!((d.safe_cost, d.unsafe_cost, d.filtered), (3.0, 18.0, false));
        let d = f.push(&[5.0], &[0.0]).unwrap();
        // [1,5] vs [0,0,0]: D = [[1,2,3],[6,6,7]] -> 7. [1,5] vs [10,10]: D = [[9,18],[14,14]] -> 14.
        assert_eq!((d.safe_cost, d.unsafe_cost, d.filtered), (7.0, 14.0, false));
        let d = f.push(&[10.0], &[0.0]).unwrap();
        assert!(d.filtered, "{d:?}");
        assert_eq!(f.len(), 3);
        f.reset();
        assert!(f.is_empty());
        assert!(!f.push(&[0.0], &[0.0]).unwrap().filtered);
    }

    #[test]
    fn an_equal_distance_filters() {
        // [4] vs [0,0,0] costs 3 * 4 = 12, vs [10,10] costs 2 * 6 = 12: a tie filters.
        let s: Strategy = "MinBothW5/MinBothW5".parse().unwrap();
        let mut f = Filter::new(&demos(Mode::State), s).unwrap();
        let d = f.push(&[4.0], &[0.0]).unwrap();
        assert_eq!((d.safe_cost, d.unsafe_cost, d.filtered), (12.0, 12.0, true));
    }

    #[test]
    fn state_action_mode_uses_the_action() {
        let s: Strategy = "MinBoth/MinBoth".parse().unwrap();
        let mut f = Filter::new(&demos(Mode::StateAction), s).unwrap();
        // Safe sequence [(0,0),(0,0)], unsafe [(10,0)]: element (0, 3).
        let d = f.push(&[0.0], &[3.0]).unwrap();
        assert_eq!(d.safe_cost, 6.0);
        assert_eq!(d.unsafe_cost, (100.0f64 + 9.0).sqrt() as f32 as f64);
    }

    #[test]
    fn bad_input_is_an_error_and_changes_nothing() {
        let s: Strategy = "MeanDemoW5/MeanDemoW10".parse().unwrap();
        let mut f = Filter::new(&demos(Mode::State), s).unwrap();
        assert!(f.push(&[1.0, 2.0], &[0.0]).unwrap_err().to_string().contains("observation"));
        assert!(f.push(&[1.0], &[]).unwrap_err().to_string().contains("action"));
        assert!(f.push(&[f64::NAN], &[0.0]).is_err());
        assert!(f.is_empty());
    }
}
