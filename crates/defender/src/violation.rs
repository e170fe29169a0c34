//! When an episode is unsafe (docs/SPEC.md, section 13): the rule that labels demonstrations,
//! the agent's own episodes joining the groups, and what DEFENDER tries to prevent.
//!
//! - **Crash** (Hopper-v5, Walker2d-v5, InvertedDoublePendulum-v5): the environment terminated the
//!   episode. The unsafe demonstration is the whole episode, up to its crash.
//! - **Cost above a limit** (Safety-Gymnasium's velocity tasks, limit 25): the episode's cost so far
//!   passes the limit. The unsafe demonstration is the episode's prefix up to and including the
//!   step that passes it: what follows is past the violation, and the filter must act before it.
//!   An episode the environment ends without passing the limit (a fall on a velocity task) is not
//!   a violation; one that reaches the horizon without passing it is safe.
//!
//! With a crash cost (1 on the crash step) and a limit of 0 the two rules agree; the crash rule is
//! kept as its own case so that the crash tasks' runs do not depend on a cost signal at all.

use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};

/// The key of a demonstration set's `meta` that says its unsafe episodes were cut where their cost
/// passed this limit (absent: labelled by crashes).
pub const EPISODE_COST_LIMIT_KEY: &str = "episode_cost_limit";

/// What makes an episode unsafe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UnsafeRule {
    /// The environment terminated it.
    Crash,
    /// Its summed cost passed this limit (strictly above).
    CostAbove(f64),
}

impl UnsafeRule {
    /// The rule of an `episode_cost_limit` setting: none is the crash rule.
    ///
    /// # Errors
    /// A limit that is not a finite number > 0, named as the setting.
    pub fn from_limit(limit: Option<f64>) -> Result<Self> {
        match limit {
            None => Ok(Self::Crash),
            Some(l) if l.is_finite() && l > 0.0 => Ok(Self::CostAbove(l)),
            Some(l) => Err(DefenderError::Config(format!(
                "[defender] episode_cost_limit = {l}: it must be a finite number > 0 (an episode is \
                 unsafe once its cost passes it; Safety-Gymnasium's limit is 25)"
            ))),
        }
    }

    /// The rule a set was labelled by: its `meta`'s limit, else the crash rule.
    ///
    /// # Errors
    /// A limit in the file that is not a finite number > 0.
    pub fn of_set(set: &EpisodeSet) -> Result<Self> {
        match set.meta().extra.get(EPISODE_COST_LIMIT_KEY) {
            None => Ok(Self::Crash),
            Some(v) => Self::from_limit(Some(v.as_f64().unwrap_or(f64::NAN))).map_err(|e| {
                DefenderError::Config(format!(
                    "{}: meta {EPISODE_COST_LIMIT_KEY}: {e}",
                    set.source().display()
                ))
            }),
        }
    }

    /// Checks that a demonstration set was labelled by this rule (its `meta` names the same
    /// limit, or none for the crash rule): groups made by another rule would teach the filter
    /// something else than what the run counts as unsafe.
    ///
    /// # Errors
    /// [`DefenderError::Config`] naming the file, the setting and how to make a fitting set.
    pub fn check_demos(self, demos: &EpisodeSet) -> Result<()> {
        let file = demos.meta().extra.get(EPISODE_COST_LIMIT_KEY).map(serde_json::Value::as_f64);
        let path = demos.source().display();
        match (self, file) {
            (Self::Crash, None) => Ok(()),
            (Self::CostAbove(l), Some(Some(f))) if f == l => Ok(()),
            (Self::CostAbove(l), None) => Err(DefenderError::Config(format!(
                "{path}: these demonstrations carry no costs (their meta has no \
                 {EPISODE_COST_LIMIT_KEY}: they were labelled by crashes), but this run's episodes are \
                 unsafe when their cost passes {l} ([defender] episode_cost_limit); collect a set on the \
                 cost task with `defender demos collect`"
            ))),
            (Self::CostAbove(l), Some(f)) => Err(DefenderError::Config(format!(
                "{path}: these demonstrations were cut where their cost passed {}, but this run's \
                 [defender] episode_cost_limit is {l}; use the same limit or collect a set with it",
                f.map_or("an unreadable value".to_string(), |f| f.to_string())
            ))),
            (Self::Crash, Some(f)) => Err(DefenderError::Config(format!(
                "{path}: these demonstrations were labelled by an episode cost above {} (meta \
                 {EPISODE_COST_LIMIT_KEY}), but this run counts crashes (no [defender] \
                 episode_cost_limit): set the limit, or use demonstrations of a crash task",
                f.map_or("an unreadable value".to_string(), |f| f.to_string())
            ))),
        }
    }
}

/// One episode's cost so far against the rule: on which step, if any, it became unsafe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViolationTracker {
    rule: UnsafeRule,
    total: f64,
    violated: bool,
}

impl ViolationTracker {
    /// A tracker at the start of an episode.
    pub fn new(rule: UnsafeRule) -> Self {
        Self { rule, total: 0.0, violated: false }
    }

    /// A new episode.
    pub fn reset(&mut self) {
        self.total = 0.0;
        self.violated = false;
    }

    /// A step that reached the environment, cost `cost` and ended the episode if `terminated`.
    /// True when this step made the episode unsafe (once per episode: later steps return false).
    pub fn step(&mut self, cost: f64, terminated: bool) -> bool {
        if self.violated {
            return false;
        }
        self.total += cost;
        self.violated = match self.rule {
            UnsafeRule::Crash => terminated,
            UnsafeRule::CostAbove(limit) => self.total > limit,
        };
        self.violated
    }

    /// Marks the episode unsafe from now on (a replay that knows the label, not the costs).
    pub fn force(&mut self) {
        self.violated = true;
    }

    /// The rule.
    pub fn rule(&self) -> UnsafeRule {
        self.rule
    }

    /// Whether the episode has become unsafe.
    pub fn violated(&self) -> bool {
        self.violated
    }

    /// The episode's label once it ended: `Some(true)` unsafe, `Some(false)` safe (it reached the
    /// horizon, `reached_horizon`, without violating), `None` neither (it ended early without
    /// violating: a fall on a cost task, or DEFENDER ended it).
    pub fn label(&self, reached_horizon: bool) -> Option<bool> {
        if self.violated {
            Some(true)
        } else if reached_horizon {
            Some(false)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode_set::Meta;

    #[test]
    fn a_cost_rule_violates_once_on_the_step_that_passes_the_limit() {
        let mut t = ViolationTracker::new(UnsafeRule::CostAbove(2.0));
        assert!(!t.step(1.0, false));
        assert!(!t.step(1.0, false), "2 is not above 2");
        assert!(t.step(1.0, false));
        assert!(!t.step(1.0, false), "only the passing step reports");
        assert_eq!(t.label(true), Some(true));
        t.reset();
        assert!(!t.step(0.0, true), "a fall without cost is no violation");
        assert_eq!((t.label(false), t.label(true)), (None, Some(false)));
    }

    #[test]
    fn the_crash_rule_is_termination_whatever_the_cost() {
        let mut t = ViolationTracker::new(UnsafeRule::Crash);
        assert!(!t.step(5.0, false));
        assert!(t.step(0.0, true));
        assert_eq!(t.label(false), Some(true));
    }

    #[test]
    fn bad_limits_and_mislabelled_demonstrations_are_refused_by_name() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = UnsafeRule::from_limit(Some(bad)).unwrap_err().to_string();
            assert!(e.contains("episode_cost_limit"), "{e}");
        }
        assert_eq!(UnsafeRule::from_limit(None).unwrap(), UnsafeRule::Crash);
        let crash_set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        let mut meta = Meta::default();
        meta.extra.insert(EPISODE_COST_LIMIT_KEY.into(), 25.0.into());
        let cost_set = EpisodeSet::new(1, 1, meta).unwrap();
        let rule = UnsafeRule::CostAbove(25.0);
        assert!(rule.check_demos(&cost_set).is_ok());
        assert!(UnsafeRule::Crash.check_demos(&crash_set).is_ok());
        let e = rule.check_demos(&crash_set).unwrap_err().to_string();
        assert!(e.contains("carry no costs") && e.contains("episode_cost_limit"), "{e}");
        let e = UnsafeRule::CostAbove(10.0).check_demos(&cost_set).unwrap_err().to_string();
        assert!(e.contains("passed 25") && e.contains("is 10"), "{e}");
        assert!(UnsafeRule::Crash.check_demos(&cost_set).is_err());
    }
}
