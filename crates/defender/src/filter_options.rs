//! The filter's precision options (`[defender.filter]`): ways to cut its false alarms, all off by
//! default, so that the filter of SPEC section 4 is what runs unless a configuration asks (the
//! `keeps-learning` profile, the default of new runs, asks for two: [`FilterOptions::keeps_learning`]).
//!
//! - `margin = m`: a step is filtered only when `Unsafe <= (1 - m) * Safe` (ties as
//!   `[defender.cost] ties` says), i.e. the trajectory must be clearly closer to the unsafe group.
//!   The margin is on the ratio of the two raw costs: both are DTW costs of the same trajectory, so
//!   the ratio does not depend on the unit of the features or on a common growth of both costs with
//!   the trajectory's length (z-scoring the costs themselves would need statistics of the costs
//!   that do not exist before training; docs/decisions.md, "Filter variants").
//! - `[defender.filter.budget] share, episodes`: the margin adapts after every episode so that the
//!   share of filtered episodes approaches `share` (a time constant of `episodes` episodes).
//! - `[defender.filter.own_episodes] keep = K`: the agent's own episodes join the demonstrations,
//!   one that reached the horizon the safe group, a crash the unsafe group (at most K per group,
//!   the oldest replaced), so the filter follows the learner's states, not only the demonstrator's.

use serde::{Deserialize, Serialize};

use crate::error::{DefenderError, Result};
use crate::trigger::{ClassifierOptions, TriggerKind};

/// The largest margin a budget may reach: at `1 - 0.99 = 0.01` of the safe cost hardly any step
/// is filtered, which is as far as "filter less" needs to go.
pub const MAX_ADAPTIVE_MARGIN: f64 = 0.99;

/// `[defender.filter]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterOptions {
    /// The decision margin `m` in `[0, 1)`; with a budget, its starting value.
    #[serde(default)]
    pub margin: f64,
    /// The filtered-rate budget (adapts the margin).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<Budget>,
    /// The agent's own episodes join the demonstrations (with the `classifier` trigger: its
    /// training data, treated the same way).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub own_episodes: Option<OwnEpisodes>,
    /// What decides to end the episode (crate::trigger; `dtw`, the default, is the filter the
    /// options above refine).
    #[serde(default, skip_serializing_if = "TriggerKind::is_dtw")]
    pub trigger: TriggerKind,
    /// The `margin` trigger's margin in (0, 1): the episode ends when the state's failure
    /// proximity (0 at the initial state, 1 on the task's failure boundary) passes
    /// `1 - task_margin`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_margin: Option<f64>,
    /// The `classifier` trigger's settings (its defaults when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub classifier: Option<ClassifierOptions>,
}

/// `[defender.filter.budget]`: after each episode the margin moves by
/// `(filtered - share) / episodes` (filtered: 1 or 0), clamped to `[0, 0.99]`: a stochastic
/// approximation whose fixed point is a filtered share of `share`, without the lag of a moving
/// window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    /// The target share of filtered episodes, in `(0, 1)`.
    pub share: f64,
    /// The time constant in episodes (>= 1): the step of the margin is `1 / episodes`.
    #[serde(default = "default_budget_episodes")]
    pub episodes: usize,
}

fn default_budget_episodes() -> usize {
    100
}

/// `[defender.filter.own_episodes]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OwnEpisodes {
    /// At most this many own episodes per group (>= 1); the oldest is replaced.
    pub keep: usize,
}

impl FilterOptions {
    /// The filter of `profile = "keeps-learning"` (docs/SPEC.md, section 11), chosen by the
    /// screen of docs/results-keeps-learning.md and fixed before its runs: a margin of 0.02 and
    /// the agent's own episodes joining the demonstrations, 50 per group.
    pub fn keeps_learning() -> Self {
        Self { margin: 0.02, own_episodes: Some(OwnEpisodes { keep: 50 }), ..Self::default() }
    }

    /// True when nothing differs from SPEC section 4's filter.
    pub fn is_spec(&self) -> bool {
        *self == Self::default()
    }

    /// The first bad value, named as in a configuration.
    ///
    /// # Errors
    /// [`DefenderError::Config`] naming the key, its value and the valid range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| Err(DefenderError::Config(what));
        if !(self.margin.is_finite() && (0.0..1.0).contains(&self.margin)) {
            return bad(format!(
                "[defender.filter] margin = {}: it must be in [0, 1) (0 is SPEC's rule; a step is \
                 filtered when Unsafe <= (1 - margin) * Safe)",
                self.margin
            ));
        }
        if let Some(b) = self.budget {
            if !(b.share.is_finite() && b.share > 0.0 && b.share < 1.0) {
                return bad(format!(
                    "[defender.filter.budget] share = {}: it must be in (0, 1), the target share of \
                     filtered episodes",
                    b.share
                ));
            }
            if b.episodes == 0 {
                return bad("[defender.filter.budget] episodes = 0: it must be at least 1".into());
            }
            if self.margin > MAX_ADAPTIVE_MARGIN {
                return bad(format!(
                    "[defender.filter] margin = {}: with a budget it starts at most at {MAX_ADAPTIVE_MARGIN}",
                    self.margin
                ));
            }
        }
        if let Some(o) = self.own_episodes
            && o.keep == 0
        {
            return bad("[defender.filter.own_episodes] keep = 0: keep at least 1 episode per group \
                        (or leave the section out)"
                .into());
        }
        match (self.trigger, self.task_margin) {
            (TriggerKind::Margin, None) => {
                return bad("[defender.filter] trigger = \"margin\" needs task_margin, in (0, 1): the \
                            episode ends when the state's failure proximity passes 1 - task_margin"
                    .into());
            }
            (TriggerKind::Margin, Some(m)) if !(m.is_finite() && m > 0.0 && m < 1.0) => {
                return bad(format!("[defender.filter] task_margin = {m}: it must be in (0, 1)"));
            }
            (TriggerKind::Margin, _) | (_, None) => {}
            (other, Some(_)) => {
                return bad(format!(
                    "[defender.filter] task_margin is the margin trigger's; trigger = \"{}\" does not read it",
                    other.as_str()
                ));
            }
        }
        if let Some(c) = self.classifier {
            if self.trigger != TriggerKind::Classifier {
                return bad(format!(
                    "[defender.filter.classifier] is the classifier trigger's; trigger = \"{}\" does not read it",
                    self.trigger.as_str()
                ));
            }
            c.validate().map_err(DefenderError::Config)?;
        }
        // margin and budget refine the DTW filter and are not read by the other triggers (a
        // profile fills margin whatever the trigger).
        Ok(())
    }

    /// A short label for tables: `spec`, or the variants joined by `+` (`margin0.2`,
    /// `budget0.2`, `own50`).
    pub fn label(&self) -> String {
        let mut parts = Vec::new();
        if self.margin > 0.0 && self.budget.is_none() {
            parts.push(format!("margin{}", self.margin));
        }
        if let Some(b) = self.budget {
            parts.push(format!("budget{}", b.share));
        }
        if let Some(o) = self.own_episodes {
            parts.push(format!("own{}", o.keep));
        }
        match self.trigger {
            TriggerKind::Dtw => {}
            TriggerKind::Margin => parts.push(format!("margin-trigger{}", self.task_margin.unwrap_or(0.0))),
            TriggerKind::Classifier => {
                let c = self.classifier.unwrap_or_default();
                parts.push(format!("classifier-p{}-h{}", c.threshold, c.horizon));
            }
            other => parts.push(other.as_str().to_string()),
        }
        if parts.is_empty() { "spec".into() } else { parts.join("+") }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_settings_are_refused_naming_the_setting() {
        let err = |o: FilterOptions| o.validate().unwrap_err().to_string();
        for m in [-0.1, 1.0, 2.0, f64::NAN] {
            assert!(err(FilterOptions { margin: m, ..Default::default() }).contains("margin"), "{m}");
        }
        let budget = |share, episodes| FilterOptions {
            budget: Some(Budget { share, episodes }),
            ..Default::default()
        };
        assert!(err(budget(0.0, 10)).contains("share = 0"));
        assert!(err(budget(1.0, 10)).contains("share = 1"));
        assert!(err(budget(0.2, 0)).contains("episodes = 0"));
        let own = FilterOptions { own_episodes: Some(OwnEpisodes { keep: 0 }), ..Default::default() };
        assert!(err(own).contains("keep = 0"));
        assert!(budget(0.2, 100).validate().is_ok());
        assert!(FilterOptions::default().validate().is_ok());
    }

    #[test]
    fn toml_round_trip_and_labels() {
        let o: FilterOptions = toml::from_str("margin = 0.2\nown_episodes = { keep = 50 }\n").unwrap();
        assert_eq!(o.label(), "margin0.2+own50");
        let b: FilterOptions = toml::from_str("budget = { share = 0.3 }\n").unwrap();
        assert_eq!(b.budget.unwrap().episodes, 100);
        assert_eq!(b.label(), "budget0.3");
        assert!(toml::from_str::<FilterOptions>("margins = 0.2\n").is_err());
        assert!(FilterOptions::default().is_spec());
        assert_eq!(FilterOptions::default().label(), "spec");
    }
}
