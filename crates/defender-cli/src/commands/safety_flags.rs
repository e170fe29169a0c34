//! `defender train`'s flags for the baselines that learn from costs (the `[safety]` section of a
//! run configuration; defender_rl::safety): one of `--penalty`, `--lagrangian`, `--pid`,
//! `--recovery`, and the Lagrangian agents' options.

use clap::Args;
use defender_config::run_config::RunConfig;
use defender_rl::safety::{LagrangianConfig, PidConfig, RecoveryConfig, SafetyConfig};

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
        conflicts_with_all = ["lagrangian", "pid", "recovery"],
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
        conflicts_with_all = ["pid", "recovery"],
        help_heading = "Baselines"
    )]
    pub lagrangian: Option<f64>,
    /// PID Lagrangian SAC (OmniSafe's SACPID: its gains kp 1e-6, ki 1e-7, kd 1e-7, updated every
    /// step) keeping the mean episode cost of the last 50 episodes at D; other gains in a
    /// configuration's [safety] ([safety] method = "pid", cost_limit = D).
    #[arg(
        long,
        value_name = "D",
        allow_negative_numbers = true,
        conflicts_with = "recovery",
        help_heading = "Baselines"
    )]
    pub pid: Option<f64>,
    /// Lagrangian SAC's multiplier rate: Adam's learning rate on lambda, one step per episode
    /// [default: 0.01] ([safety] lambda_lr).
    #[arg(long, value_name = "LR", requires = "lagrangian", help_heading = "Baselines")]
    pub lambda_lr: Option<f64>,
    /// Normalise the cost the cost critic learns from, as OmniSafe's cost_normalize: (c - mean)
    /// / std of the costs so far, clipped to +-5 ([safety] cost_normalize = true).
    #[arg(long, help_heading = "Baselines")]
    pub cost_normalize: bool,
    /// The Lagrangian agents' largest cost of one step [default: 1] ([safety] cost_max; with
    /// --charge-filtered a filtered step costs the learner up to the episode limit plus one).
    #[arg(long, value_name = "C", help_heading = "Baselines")]
    pub cost_max: Option<f64>,
    /// Clip the gradient norms of the actor, the reward critics and the cost critic at N, as
    /// OmniSafe's max_grad_norm (40) ([safety] max_grad_norm = N).
    #[arg(long, value_name = "N", help_heading = "Baselines")]
    pub max_grad_norm: Option<f64>,
    /// Recovery RL (model-free): a safety critic and a recovery policy pretrained on the
    /// demonstrations; the recovery policy acts when Q_risk(s, a) > EPS_RISK, in (0, 1)
    /// ([safety] method = "recovery", eps_risk = EPS_RISK).
    #[arg(long, value_name = "EPS_RISK", allow_negative_numbers = true, help_heading = "Baselines")]
    pub recovery: Option<f64>,
    /// Recovery RL's safety discount, in (0, 1) [default: 0.8] ([safety] gamma_risk).
    #[arg(long, value_name = "G", requires = "recovery", help_heading = "Baselines")]
    pub gamma_risk: Option<f64>,
    /// Recovery RL's share of each safety-critic batch drawn from the stored violations, in
    /// [0, 1) [default: 0.3, their scripts'; 0: uniform batches] ([safety] pos_fraction).
    #[arg(long, value_name = "F", requires = "recovery", help_heading = "Baselines")]
    pub pos_fraction: Option<f64>,
}

impl SafetyFlags {
    /// Sets `[safety]` from the flags given (a flag replaces the configuration's section, except
    /// that `--recovery` keeps a configuration's other Recovery RL settings and `--pid` its
    /// other PID settings).
    ///
    /// # Errors
    /// `--cost-normalize` or `--max-grad-norm` without a Lagrangian agent.
    pub fn apply(&self, config: &mut RunConfig) -> anyhow::Result<()> {
        if let Some(penalty) = self.penalty {
            config.safety = Some(SafetyConfig::Penalty { penalty });
        }
        if let Some(cost_limit) = self.lagrangian {
            config.safety = Some(SafetyConfig::Lagrangian(LagrangianConfig {
                cost_limit,
                lambda_lr: self.lambda_lr.unwrap_or(LagrangianConfig::default().lambda_lr),
                ..LagrangianConfig::default()
            }));
        }
        if let Some(cost_limit) = self.pid {
            let base = match &config.safety {
                Some(SafetyConfig::Pid(p)) => p.clone(),
                _ => PidConfig::default(),
            };
            config.safety = Some(SafetyConfig::Pid(PidConfig { cost_limit, ..base }));
        }
        if let Some(eps_risk) = self.recovery {
            // Over a configuration's own Recovery RL settings: its `pretrain_steps` (and
            // `gamma_risk` without --gamma-risk) stay.
            let (gamma_risk, base) = match &config.safety {
                Some(SafetyConfig::Recovery(r)) => (r.gamma_risk, r.clone()),
                _ => (DEFAULT_GAMMA_RISK, RecoveryConfig::default()),
            };
            let pos_fraction = self.pos_fraction.unwrap_or(base.pos_fraction);
            config.safety = Some(SafetyConfig::Recovery(RecoveryConfig {
                eps_risk,
                gamma_risk: self.gamma_risk.unwrap_or(gamma_risk),
                pos_fraction,
                ..base
            }));
        }
        if self.cost_normalize || self.max_grad_norm.is_some() || self.cost_max.is_some() {
            let (normalize, clip, cost_max) = match &mut config.safety {
                Some(SafetyConfig::Lagrangian(l)) => {
                    (&mut l.cost_normalize, &mut l.max_grad_norm, &mut l.cost_max)
                }
                Some(SafetyConfig::Pid(p)) => (&mut p.cost_normalize, &mut p.max_grad_norm, &mut p.cost_max),
                _ => anyhow::bail!(
                    "--cost-normalize, --max-grad-norm and --cost-max are options of the Lagrangian agents: \
                     give --lagrangian or --pid (or a configuration with [safety] method = \"lagrangian\" or \"pid\")"
                ),
            };
            *normalize |= self.cost_normalize;
            if self.max_grad_norm.is_some() {
                *clip = self.max_grad_norm;
            }
            if let Some(c) = self.cost_max {
                *cost_max = c;
            }
        }
        Ok(())
    }
}
