//! The field's other ways to learn with few violations, as agents that read the step's cost
//! ([`crate::Step::cost`]): the baselines DEFENDER is compared with (docs/results-baselines.md).
//! A run's `[safety]` section chooses one; without it the agent ignores costs.
//!
//! - `penalty`: the stored reward is `r - penalty * c` ([`penalty::Penalized`], any algorithm);
//! - `lagrangian`: SAC with a cost critic and a Lagrange multiplier, as OmniSafe's SACLag;
//! - `pid`: the same SAC with the multiplier set by a PID controller (Stooke, Achiam and Abbeel
//!   2020), as OmniSafe's SACPID;
//! - `recovery`: Recovery RL (Thananjeyan et al. 2021), model-free: a safety critic pretrained
//!   on the demonstrations and a recovery policy that takes over when it predicts a violation.
//!
//! The episode returns a run records stay the task's own (a penalty changes what the agent
//! learns from, never what is reported).

pub(crate) mod cost_critic;
pub mod cost_normalizer;
mod episode_costs;
pub mod lagrangian;
pub mod multiplier;
pub mod penalty;
pub mod pid;
pub mod recovery;
mod recovery_policy;
mod risk_batches;
mod risk_critic;
pub mod risk_signal;

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
    /// PID Lagrangian SAC (OmniSafe's SACPID rule).
    Pid(PidConfig),
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
    /// The largest cost of one step (1 on every shipped task: a crash, or a step over the
    /// velocity limit). A larger or negative cost is refused.
    #[serde(default = "default_cost_max")]
    pub cost_max: f64,
    /// `Q_c` kept within what a discounted sum of costs can be, `[c_min, c_max] / (1 - gamma)`,
    /// by a scaled sigmoid output; `false`: the unbounded linear output of the first runs
    /// (`lagrangian-v1`).
    #[serde(default = "default_true")]
    pub bounded_cost_critic: bool,
    /// OmniSafe's `cost_normalize`: each step's cost, before the cost critic sees it, is
    /// `(c - mean) / max(std, 0.01)` of the costs so far, clipped to +-5. `J_c` reads raw costs.
    #[serde(default)]
    pub cost_normalize: bool,
    /// OmniSafe's `max_grad_norm` (40): the actor's, the reward critics' (jointly) and the cost
    /// critic's gradients are each scaled to this norm when longer. Absent: no clipping.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_grad_norm: Option<f64>,
}

/// PID Lagrangian SAC's settings: OmniSafe 0.5's `PIDLagrangian` (`common/pid_lagrange.py`) with
/// the defaults of its `configs/off-policy/SACPID.yaml`. The controller steps once per
/// environment step once learning has started, as OmniSafe's `_update` calls `pid_update`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidConfig {
    /// `d`: the target mean episode cost (as [`LagrangianConfig::cost_limit`]).
    pub cost_limit: f64,
    /// The integral term's initial value (OmniSafe's `lagrangian_multiplier_init`: 0.001).
    #[serde(default = "default_lambda_init")]
    pub lambda_init: f64,
    /// The proportional gain `K_p` (OmniSafe: 1e-6).
    #[serde(default = "default_pid_kp")]
    pub kp: f64,
    /// The integral gain `K_i` (OmniSafe: 1e-7).
    #[serde(default = "default_pid_ki")]
    pub ki: f64,
    /// The derivative gain `K_d` (OmniSafe: 1e-7).
    #[serde(default = "default_pid_kd")]
    pub kd: f64,
    /// How many updates back the derivative compares with (`pid_d_delay`: 10).
    #[serde(default = "default_d_delay")]
    pub d_delay: usize,
    /// The EMA factor of the proportional error (`pid_delta_p_ema_alpha`: 0.95).
    #[serde(default = "default_ema")]
    pub delta_p_ema_alpha: f64,
    /// The EMA factor of the cost the derivative reads (`pid_delta_d_ema_alpha`: 0.95).
    #[serde(default = "default_ema")]
    pub delta_d_ema_alpha: f64,
    /// OmniSafe's `sum_norm` (true): with it (or `diff_norm`) `penalty_max` does not cap.
    #[serde(default = "default_true")]
    pub sum_norm: bool,
    /// OmniSafe's `diff_norm` (false): the integral and the output clamped to [0, 1].
    #[serde(default)]
    pub diff_norm: bool,
    /// The output's cap when neither norm is set (`penalty_max`: 100).
    #[serde(default = "default_penalty_max")]
    pub penalty_max: f64,
    /// `J_c` is the mean cost of this many last training episodes.
    #[serde(default = "default_window")]
    pub window: usize,
    /// The largest cost of one step (1 on every shipped task: a crash, or a step over the
    /// velocity limit). A larger or negative cost is refused.
    #[serde(default = "default_cost_max")]
    pub cost_max: f64,
    /// `Q_c` kept within what a discounted sum of costs can be, `[c_min, c_max] / (1 - gamma)`,
    /// by a scaled sigmoid output; `false`: the unbounded linear output of the first runs
    /// (`lagrangian-v1`).
    #[serde(default = "default_true")]
    pub bounded_cost_critic: bool,
    /// OmniSafe's `cost_normalize`: each step's cost, before the cost critic sees it, is
    /// `(c - mean) / max(std, 0.01)` of the costs so far, clipped to +-5. `J_c` reads raw costs.
    #[serde(default)]
    pub cost_normalize: bool,
    /// OmniSafe's `max_grad_norm` (40): the actor's, the reward critics' (jointly) and the cost
    /// critic's gradients are each scaled to this norm when longer. Absent: no clipping.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_grad_norm: Option<f64>,
}

/// The cost critic's settings, as both Lagrangian agents hold them (docs/decisions-baselines.md,
/// "The cost critic repaired"); see [`LagrangianConfig`]'s fields of the same names.
#[derive(Debug, Clone, PartialEq)]
pub struct CostCriticConfig {
    /// The largest cost of one step.
    pub cost_max: f64,
    /// `Q_c` bounded by a scaled sigmoid.
    pub bounded_cost_critic: bool,
    /// Costs normalised as OmniSafe's `CostNormalize`.
    pub cost_normalize: bool,
    /// Gradient-norm clipping.
    pub max_grad_norm: Option<f64>,
}

impl Default for CostCriticConfig {
    /// The repaired critic: bounded, raw costs of at most 1, no clipping.
    fn default() -> Self {
        Self {
            cost_max: default_cost_max(),
            bounded_cost_critic: true,
            cost_normalize: false,
            max_grad_norm: None,
        }
    }
}

impl CostCriticConfig {
    fn validate(&self) -> Result<(), RlError> {
        if !(self.cost_max.is_finite() && self.cost_max > 0.0) {
            return Err(bad("cost_max", self.cost_max, "a finite number > 0"));
        }
        if let Some(n) = self.max_grad_norm
            && !(n.is_finite() && n > 0.0)
        {
            return Err(bad("max_grad_norm", n, "a finite number > 0"));
        }
        Ok(())
    }
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
    /// The share of each safety-critic batch drawn from the stored violations, in [0, 1) (their
    /// scripts' `pos_fraction` 0.3; 0: uniform batches, as the first runs, `recovery-v1`).
    #[serde(default = "default_pos_fraction")]
    pub pos_fraction: f64,
}

impl Default for LagrangianConfig {
    /// OmniSafe's initial multiplier and this project's rate and window; `cost_limit` 0.
    fn default() -> Self {
        Self {
            cost_limit: 0.0,
            lambda_init: default_lambda_init(),
            lambda_lr: default_lambda_lr(),
            window: default_window(),
            cost_max: default_cost_max(),
            bounded_cost_critic: true,
            cost_normalize: false,
            max_grad_norm: None,
        }
    }
}

impl Default for PidConfig {
    /// OmniSafe's SACPID gains and this project's window; `cost_limit` 0.
    fn default() -> Self {
        Self {
            cost_limit: 0.0,
            lambda_init: default_lambda_init(),
            kp: default_pid_kp(),
            ki: default_pid_ki(),
            kd: default_pid_kd(),
            d_delay: default_d_delay(),
            delta_p_ema_alpha: default_ema(),
            delta_d_ema_alpha: default_ema(),
            sum_norm: true,
            diff_norm: false,
            penalty_max: default_penalty_max(),
            window: default_window(),
            cost_max: default_cost_max(),
            bounded_cost_critic: true,
            cost_normalize: false,
            max_grad_norm: None,
        }
    }
}

impl Default for RecoveryConfig {
    /// Their pretraining length; `gamma_risk` and `eps_risk` in the middle of their scripts'
    /// ranges (a run sets both).
    fn default() -> Self {
        Self {
            gamma_risk: 0.8,
            eps_risk: 0.3,
            pretrain_steps: default_pretrain_steps(),
            pos_fraction: default_pos_fraction(),
        }
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
fn default_pos_fraction() -> f64 {
    0.3
}
fn default_pid_kp() -> f64 {
    1e-6
}
fn default_pid_ki() -> f64 {
    1e-7
}
fn default_pid_kd() -> f64 {
    1e-7
}
fn default_d_delay() -> usize {
    10
}
fn default_ema() -> f64 {
    0.95
}
fn default_penalty_max() -> f64 {
    100.0
}
fn default_cost_max() -> f64 {
    1.0
}
fn default_true() -> bool {
    true
}

fn bad(field: &'static str, value: impl std::fmt::Display, expected: &'static str) -> RlError {
    RlError::Config { field, value: value.to_string(), expected }
}

impl LagrangianConfig {
    /// Its cost critic's settings.
    pub fn critic(&self) -> CostCriticConfig {
        CostCriticConfig {
            cost_max: self.cost_max,
            bounded_cost_critic: self.bounded_cost_critic,
            cost_normalize: self.cost_normalize,
            max_grad_norm: self.max_grad_norm,
        }
    }
}

impl PidConfig {
    /// Its cost critic's settings.
    pub fn critic(&self) -> CostCriticConfig {
        CostCriticConfig {
            cost_max: self.cost_max,
            bounded_cost_critic: self.bounded_cost_critic,
            cost_normalize: self.cost_normalize,
            max_grad_norm: self.max_grad_norm,
        }
    }
}

impl SafetyConfig {
    /// The method's name in a configuration (`method = "..."`) and in run names.
    pub fn method(&self) -> &'static str {
        match self {
            Self::Penalty { .. } => "penalty",
            Self::Lagrangian(_) => "lagrangian",
            Self::Pid(_) => "pid",
            Self::Recovery(_) => "recovery",
        }
    }

    /// The largest cost of one step its cost critic accepts (the Lagrangian agents'); `None` for
    /// the others.
    pub fn cost_max(&self) -> Option<f64> {
        match self {
            Self::Lagrangian(l) => Some(l.cost_max),
            Self::Pid(p) => Some(p.cost_max),
            Self::Penalty { .. } | Self::Recovery(_) => None,
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
                c.critic().validate()?;
            }
            Self::Pid(c) => {
                if !(c.cost_limit.is_finite() && c.cost_limit >= 0.0) {
                    return Err(bad("cost_limit", c.cost_limit, "a finite number >= 0"));
                }
                if !(c.lambda_init.is_finite() && c.lambda_init >= 0.0) {
                    return Err(bad("lambda_init", c.lambda_init, "a finite number >= 0"));
                }
                for (field, v) in [("kp", c.kp), ("ki", c.ki), ("kd", c.kd), ("penalty_max", c.penalty_max)] {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(bad(field, v, "a finite number >= 0"));
                    }
                }
                for (field, v) in
                    [("delta_p_ema_alpha", c.delta_p_ema_alpha), ("delta_d_ema_alpha", c.delta_d_ema_alpha)]
                {
                    if !(0.0..1.0).contains(&v) {
                        return Err(bad(field, v, "a number in [0, 1)"));
                    }
                }
                if c.d_delay == 0 {
                    return Err(bad("d_delay", 0, "at least 1 update"));
                }
                if c.window == 0 {
                    return Err(bad("window", 0, "at least 1 episode"));
                }
                c.critic().validate()?;
            }
            Self::Recovery(c) => {
                if !(c.gamma_risk > 0.0 && c.gamma_risk < 1.0) {
                    return Err(bad("gamma_risk", c.gamma_risk, "a number in (0, 1)"));
                }
                if !(c.eps_risk > 0.0 && c.eps_risk < 1.0) {
                    return Err(bad("eps_risk", c.eps_risk, "a number in (0, 1)"));
                }
                if !(0.0..1.0).contains(&c.pos_fraction) {
                    return Err(bad("pos_fraction", c.pos_fraction, "a share of the batch in [0, 1)"));
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
        let limit = match self {
            Self::Lagrangian(c) => Some(c.cost_limit),
            Self::Pid(c) => Some(c.cost_limit),
            _ => None,
        };
        if let Some(limit) = limit
            && limit > 1.0
        {
            return Err(bad(
                "cost_limit",
                limit,
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
        let lag = |d| LagrangianConfig { cost_limit: d, ..LagrangianConfig::default() };
        assert_eq!(field(SafetyConfig::Lagrangian(lag(1.5))), "cost_limit");
        assert_eq!(field(SafetyConfig::Lagrangian(lag(-0.1))), "cost_limit");
        assert!(SafetyConfig::Lagrangian(lag(25.0)).validate().is_ok());
        let rec = |g, e| RecoveryConfig { gamma_risk: g, eps_risk: e, pretrain_steps: 10, pos_fraction: 0.3 };
        assert_eq!(field(SafetyConfig::Recovery(rec(0.8, 1.0))), "eps_risk");
        assert_eq!(field(SafetyConfig::Recovery(rec(0.0, 0.3))), "gamma_risk");
    }
}
