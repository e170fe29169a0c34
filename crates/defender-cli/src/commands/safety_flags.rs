//! `defender train`'s flags for the baselines that learn from costs (the `[safety]` section of a
//! run configuration; defender_rl::safety): one of `--penalty`, `--lagrangian`, `--recovery`.

use clap::Args;
use defender_config::run_config::RunConfig;
use defender_rl::safety::{LagrangianConfig, RecoveryConfig, SafetyConfig};

/// The Recovery RL safety discount `--recovery` takes without `--gamma-risk`.
pub const DEFAULT_GAMMA_RISK: f64 = 0.8;

/// The flags.
#[derive(Debug, Args)]
pub struct SafetyFlags {
    /// Crash-penalty baseline: the agent learns from `reward - P x cost` (a crash step costs 1);
    /// the recorded returns stay the task's ([safety] method = "penalty", penalty = P).
    #[arg(
        long,
        value_name = "P",
        allow_negative_numbers = true,
        conflicts_with_all = ["lagrangian", "recovery"],
        help_heading = "Baselines"
    )]
    pub penalty: Option<f64>,
    /// Lagrangian SAC (OmniSafe's SACLag rule) keeping the mean episode cost of the last 50
    /// episodes at D; with the crash cost, D is a target crash probability per episode in [0, 1]
    /// ([safety] method = "lagrangian", cost_limit = D).
    #[arg(
        long,
        value_name = "D",
        allow_negative_numbers = true,
        conflicts_with = "recovery",
        help_heading = "Baselines"
    )]
    pub lagrangian: Option<f64>,
    /// Recovery RL (model-free): a safety critic and a recovery policy pretrained on the
    /// demonstrations; the recovery policy acts when Q_risk(s, a) > EPS_RISK, in (0, 1)
    /// ([safety] method = "recovery", eps_risk = EPS_RISK).
    #[arg(long, value_name = "EPS_RISK", allow_negative_numbers = true, help_heading = "Baselines")]
    pub recovery: Option<f64>,
    /// Recovery RL's safety discount, in (0, 1) [default: 0.8] ([safety] gamma_risk).
    #[arg(long, value_name = "G", requires = "recovery", help_heading = "Baselines")]
    pub gamma_risk: Option<f64>,
}

impl SafetyFlags {
    /// Sets `[safety]` from the flags given (a flag replaces the configuration's section, except
    /// that `--recovery` keeps a configuration's other Recovery RL settings).
    pub fn apply(&self, config: &mut RunConfig) {
        if let Some(penalty) = self.penalty {
            config.safety = Some(SafetyConfig::Penalty { penalty });
        }
        if let Some(cost_limit) = self.lagrangian {
            config.safety = Some(SafetyConfig::Lagrangian(LagrangianConfig {
                cost_limit,
                ..LagrangianConfig::default()
            }));
        }
        if let Some(eps_risk) = self.recovery {
            // Over a configuration's own Recovery RL settings: its `pretrain_steps` (and
            // `gamma_risk` without --gamma-risk) stay.
            let (gamma_risk, base) = match &config.safety {
                Some(SafetyConfig::Recovery(r)) => (r.gamma_risk, r.clone()),
                _ => (DEFAULT_GAMMA_RISK, RecoveryConfig::default()),
            };
            config.safety = Some(SafetyConfig::Recovery(RecoveryConfig {
                eps_risk,
                gamma_risk: self.gamma_risk.unwrap_or(gamma_risk),
                ..base
            }));
        }
    }
}
