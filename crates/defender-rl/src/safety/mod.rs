//! The field's other ways to learn with few violations, as agents that read the step's cost
//! ([`crate::Step::cost`]): the baselines DEFENDER is compared with (docs/results-baselines.md).
//! A run's `[safety]` section chooses one; without it the agent ignores costs.
//!
//! - `penalty`: the stored reward is `r - penalty * c` ([`penalty::Penalized`], any algorithm);
//! - `lagrangian`: SAC with a cost critic and a Lagrange multiplier, as OmniSafe's SACLag;
//! - `recovery`: Recovery RL (Thananjeyan et al. 2021), model-free: a safety critic pretrained
//!   on the demonstrations and a recovery policy that takes over when it predicts a violation.
//!
//! The episode returns a run records stay the task's own (a penalty changes what the agent
//! learns from, never what is reported).

pub(crate) mod cost_critic;
pub mod lagrangian;
pub mod multiplier;
pub mod penalty;
pub mod recovery;
mod recovery_policy;
mod risk_critic;

use serde::{Deserialize, Serialize};

use crate::error::RlError;

/// A run's `[safety]` section: which baseline, with its knobs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "kebab-case")]
pub enum SafetyConfig {
    /// The reward of a step minus `penalty` times its cost.
    Penalty {
        /// `p >= 0`: what one unit of cost is worth in reward.
        penalty: f64,
    },
    /// Lagrangian SAC (OmniSafe's SACLag rule).
    Lagrangian(LagrangianConfig),
    /// Recovery RL, model-free.
    Recovery(RecoveryConfig),
}

/// Lagrangian SAC's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LagrangianConfig {
    /// `d`: the target mean episode cost. With a crash cost (1 per crash) it is the target crash
    /// probability per episode, in [0, 1].
    pub cost_limit: f64,
    /// The multiplier's initial value (OmniSafe: 0.001).
    #[serde(default = "default_lambda_init")]
    pub lambda_init: f64,
    /// Adam's learning rate on the multiplier.
    #[serde(default = "default_lambda_lr")]
    pub lambda_lr: f64,
    /// `J_c` is the mean cost of this many last training episodes.
    #[serde(default = "default_window")]
    pub window: usize,
}

/// Recovery RL's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecoveryConfig {
    /// The safety critic's discount, in (0, 1) (their scripts: 0.5-0.85).
    pub gamma_risk: f64,
    /// The threshold on `Q_risk(s, a)` above which the recovery policy acts, in (0, 1) (their
    /// scripts: 0.1-0.35).
    pub eps_risk: f64,
    /// Gradient steps of the safety critic and the recovery policy on the demonstrations before
    /// training (their default: 10,000).
    #[serde(default = "default_pretrain_steps")]
    pub pretrain_steps: u64,
}

impl Default for LagrangianConfig {
    /// OmniSafe's initial multiplier and this project's rate and window; `cost_limit` 0.
    fn default() -> Self {
        Self {
            cost_limit: 0.0,
            lambda_init: default_lambda_init(),
            lambda_lr: default_lambda_lr(),
            window: default_window(),
        }
    }
}

impl Default for RecoveryConfig {
    /// Their pretraining length; `gamma_risk` and `eps_risk` in the middle of their scripts'
    /// ranges (a run sets both).
    fn default() -> Self {
        Self { gamma_risk: 0.8, eps_risk: 0.3, pretrain_steps: default_pretrain_steps() }
    }
}

fn default_lambda_init() -> f64 {
    0.001
}
fn default_lambda_lr() -> f64 {
    0.01
}
fn default_window() -> usize {
    50
}
fn default_pretrain_steps() -> u64 {
    10_000
}

fn bad(field: &'static str, value: impl std::fmt::Display, expected: &'static str) -> RlError {
    RlError::Config { field, value: value.to_string(), expected }
}

impl SafetyConfig {
    /// The method's name in a configuration (`method = "..."`) and in run names.
    pub fn method(&self) -> &'static str {
        match self {
            Self::Penalty { .. } => "penalty",
            Self::Lagrangian(_) => "lagrangian",
            Self::Recovery(_) => "recovery",
        }
    }

    /// Checks the knobs.
    ///
    /// # Errors
    /// [`RlError::Config`] naming the first bad key.
    pub fn validate(&self) -> Result<(), RlError> {
        match self {
            Self::Penalty { penalty } => {
                if !(penalty.is_finite() && *penalty >= 0.0) {
                    return Err(bad("penalty", penalty, "a finite number >= 0"));
                }
            }
            Self::Lagrangian(c) => {
                if !(c.cost_limit.is_finite() && c.cost_limit >= 0.0) {
                    return Err(bad("cost_limit", c.cost_limit, "a finite number >= 0"));
                }
                if !(c.lambda_init.is_finite() && c.lambda_init >= 0.0) {
                    return Err(bad("lambda_init", c.lambda_init, "a finite number >= 0"));
                }
                if !(c.lambda_lr.is_finite() && c.lambda_lr > 0.0) {
                    return Err(bad("lambda_lr", c.lambda_lr, "a finite number > 0"));
                }
                if c.window == 0 {
                    return Err(bad("window", 0, "at least 1 episode"));
                }
            }
            Self::Recovery(c) => {
                if !(c.gamma_risk > 0.0 && c.gamma_risk < 1.0) {
                    return Err(bad("gamma_risk", c.gamma_risk, "a number in (0, 1)"));
                }
                if !(c.eps_risk > 0.0 && c.eps_risk < 1.0) {
                    return Err(bad("eps_risk", c.eps_risk, "a number in (0, 1)"));
                }
            }
        }
        Ok(())
    }

    /// Checks the knobs against a task whose episode cost is a crash (0 or 1 per episode): a
    /// Lagrangian `cost_limit` is then a crash probability, in [0, 1].
    ///
    /// # Errors
    /// [`RlError::Config`] naming the key.
    pub fn validate_for_crash_cost(&self) -> Result<(), RlError> {
        self.validate()?;
        if let Self::Lagrangian(c) = self
            && c.cost_limit > 1.0
        {
            return Err(bad(
                "cost_limit",
                c.cost_limit,
                "a crash probability per episode in [0, 1] (the task's cost is 1 per crash)",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> SafetyConfig {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn each_method_reads_with_its_defaults() {
        assert_eq!(parse("method = \"penalty\"\npenalty = 10.0"), SafetyConfig::Penalty { penalty: 10.0 });
        let SafetyConfig::Lagrangian(l) = parse("method = \"lagrangian\"\ncost_limit = 0.1") else {
            panic!()
        };
        assert_eq!((l.lambda_init, l.window), (0.001, 50));
        let SafetyConfig::Recovery(r) = parse("method = \"recovery\"\ngamma_risk = 0.8\neps_risk = 0.3")
        else {
            panic!()
        };
        assert_eq!(r.pretrain_steps, 10_000);
        assert!(toml::from_str::<SafetyConfig>("method = \"shield\"").is_err());
    }

    #[test]
    fn bad_knobs_are_refused_naming_the_key() {
        let field = |c: SafetyConfig| match c.validate_for_crash_cost() {
            Err(RlError::Config { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(SafetyConfig::Penalty { penalty: -1.0 }), "penalty");
        let lag = |d| LagrangianConfig { cost_limit: d, lambda_init: 0.001, lambda_lr: 0.01, window: 50 };
        assert_eq!(field(SafetyConfig::Lagrangian(lag(1.5))), "cost_limit");
        assert_eq!(field(SafetyConfig::Lagrangian(lag(-0.1))), "cost_limit");
        assert!(SafetyConfig::Lagrangian(lag(25.0)).validate().is_ok());
        let rec = |g, e| RecoveryConfig { gamma_risk: g, eps_risk: e, pretrain_steps: 10 };
        assert_eq!(field(SafetyConfig::Recovery(rec(0.8, 1.0))), "eps_risk");
        assert_eq!(field(SafetyConfig::Recovery(rec(0.0, 0.3))), "gamma_risk");
    }
}
