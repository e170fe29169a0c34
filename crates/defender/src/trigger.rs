//! What decides to end the episode (`[defender.filter] trigger`, docs/SPEC.md section 15). The
//! end itself is SPEC section 5's whatever decides it: the action is not executed, the dynamics
//! model supplies the next state, the reward is `R_task`, the step is terminal. The triggers:
//!
//! - `dtw` (the default): the DTW filter of SPEC section 4 with its precision options.
//! - `classifier`: a small network trained on the same demonstrations, which ends the episode
//!   when its probability that the recent window lies within `horizon` steps of a failure passes
//!   `threshold` (crate::classifier).
//! - `risk-critic`: Recovery RL's safety critic `Q_risk(s, a)`, pretrained on the same
//!   demonstrations and updated online, which ends the episode when `Q_risk > eps_risk`
//!   instead of handing over to a recovery policy (its agent raises a [`RiskSignal`]).
//! - `margin`: the task's own failure condition tightened by `task_margin` (no demonstrations;
//!   task knowledge the others do not use): ends when the state's failure proximity
//!   ([`defender_rl::Env::failure_proximity`]) passes `1 - task_margin`.
//! - `violation` (a task whose safety is a cost): ends the episode once its cost has passed the
//!   limit: the reactive end of an early-terminated MDP (Sun et al. 2021), no prediction.

use serde::{Deserialize, Serialize};

pub use defender_rl::RiskSignal;

/// The trigger's name (`[defender.filter] trigger`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TriggerKind {
    /// The DTW filter (SPEC section 4).
    #[default]
    Dtw,
    /// A classifier of the recent window trained on the demonstrations.
    Classifier,
    /// Recovery RL's safety critic (needs `[safety] method = "recovery"`).
    RiskCritic,
    /// The task's failure condition tightened by a margin.
    Margin,
    /// The episode's cost passed the limit (cost tasks).
    Violation,
}

impl TriggerKind {
    /// Whether it is the default (left out of a saved configuration).
    pub fn is_dtw(&self) -> bool {
        *self == Self::Dtw
    }

    /// The name in configurations and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Dtw => "dtw",
            Self::Classifier => "classifier",
            Self::RiskCritic => "risk-critic",
            Self::Margin => "margin",
            Self::Violation => "violation",
        }
    }

    /// Every trigger, in the order of the docs.
    pub const ALL: [Self; 5] = [Self::Dtw, Self::Classifier, Self::RiskCritic, Self::Margin, Self::Violation];
}

impl std::str::FromStr for TriggerKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL.into_iter().find(|k| k.as_str() == s).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|k| k.as_str()).collect();
            format!("unknown trigger {s:?}; expected one of {}", names.join(", "))
        })
    }
}

/// `[defender.filter.classifier]`: the `classifier` trigger's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassifierOptions {
    /// The episode ends when the probability passes this, in (0, 1).
    #[serde(default = "default_threshold")]
    pub threshold: f64,
    /// `H`: a step of an unsafe demonstration is labelled unsafe when its failure is at most
    /// this many steps ahead (the failing step itself is 1 ahead).
    #[serde(default = "default_horizon")]
    pub horizon: usize,
    /// The recent window it reads: the last this many elements (`s_t`, or `(s_t, a_t)` in
    /// state-action mode), the first repeated before the episode has that many.
    #[serde(default = "default_window")]
    pub window: usize,
    /// Gradient steps on the demonstrations before the first episode.
    #[serde(default = "default_pretrain_steps")]
    pub pretrain_steps: usize,
    /// Gradient steps after each own episode joins (with `[defender.filter.own_episodes]`).
    #[serde(default = "default_update_steps")]
    pub update_steps: usize,
}

fn default_threshold() -> f64 {
    0.5
}
fn default_horizon() -> usize {
    20
}
fn default_window() -> usize {
    5
}
fn default_pretrain_steps() -> usize {
    3000
}
fn default_update_steps() -> usize {
    50
}

impl Default for ClassifierOptions {
    fn default() -> Self {
        Self {
            threshold: default_threshold(),
            horizon: default_horizon(),
            window: default_window(),
            pretrain_steps: default_pretrain_steps(),
            update_steps: default_update_steps(),
        }
    }
}

impl ClassifierOptions {
    /// The first bad value, named as in a configuration.
    pub(crate) fn validate(&self) -> std::result::Result<(), String> {
        let key = "[defender.filter.classifier]";
        if !(self.threshold.is_finite() && self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(format!("{key} threshold = {}: it must be in (0, 1)", self.threshold));
        }
        if self.horizon == 0 {
            return Err(format!("{key} horizon = 0: it must be at least 1 (the failing step)"));
        }
        if !(1..=64).contains(&self.window) {
            return Err(format!("{key} window = {}: it must be in 1..=64", self.window));
        }
        Ok(())
    }
}

/// The trigger a `DefenderEnv` runs, as built from its configuration (the DTW filter itself is
/// the environment's `AdaptiveFilter`).
#[derive(Debug)]
pub(crate) enum Gate {
    Dtw,
    /// Ends when the failure proximity passes `threshold` (`1 - task_margin`).
    Margin {
        threshold: f64,
    },
    /// Ends once the episode's cost has passed `limit`.
    Violation {
        limit: f64,
    },
    /// Ends when the agent raised the signal (set by `DefenderEnv::set_risk_signal`).
    RiskCritic(Option<RiskSignal>),
    Classifier(Box<crate::classifier::Classifier>),
}
