//! Hyperparameters: one documented struct per algorithm, with Stable-Baselines3's names and
//! defaults (TOML keys are the field names; unknown keys are refused).
//!
//! One deliberate difference from SB3: `learning_starts` defaults to 5000 (CleanRL's value; the
//! RL Zoo uses 10000 for the MuJoCo tasks) rather than SB3's 100, because a policy trained from
//! 100 random transitions wastes its first updates and the MuJoCo tasks are the target here. Set
//! `learning_starts = 100` to reproduce SB3 exactly.

use serde::{Deserialize, Serialize};

use crate::error::RlError;

/// The entropy coefficient of SAC (SB3's `ent_coef`).
///
/// In TOML: `ent_coef = "auto"` (learned, starting at 1.0, target entropy `-act_dim`),
/// `ent_coef = "auto_0.1"` (learned, starting at 0.1, as SB3's string), `ent_coef = 0.2` (fixed), or
/// `ent_coef = { init = 1.0, target_entropy = -3.0 }` (learned, explicit target).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "EntCoefRepr", into = "EntCoefRepr")]
pub enum EntCoef {
    /// Learned by gradient descent on `log_alpha` so that the policy's entropy tracks a target.
    Auto {
        /// Target entropy; `None` means `-act_dim` (SB3's and the SAC paper's heuristic).
        target_entropy: Option<f32>,
        /// Initial value of alpha (`log_alpha = ln(init)`); SB3 starts at 1.0.
        init: f32,
    },
    /// A constant alpha.
    Fixed(f32),
}

impl Default for EntCoef {
    fn default() -> Self {
        Self::Auto { target_entropy: None, init: 1.0 }
    }
}

/// How `EntCoef` looks on disk.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum EntCoefRepr {
    Fixed(f32),
    Named(String),
    Table {
        #[serde(default = "one")]
        init: f32,
        #[serde(default)]
        target_entropy: Option<f32>,
    },
}

fn one() -> f32 {
    1.0
}

impl TryFrom<EntCoefRepr> for EntCoef {
    type Error = String;
    fn try_from(r: EntCoefRepr) -> Result<Self, String> {
        Ok(match r {
            EntCoefRepr::Fixed(v) => Self::Fixed(v),
            EntCoefRepr::Table { init, target_entropy } => Self::Auto { target_entropy, init },
            EntCoefRepr::Named(s) if s == "auto" => Self::default(),
            EntCoefRepr::Named(s) => {
                let init = s.strip_prefix("auto_").and_then(|v| v.parse::<f32>().ok()).ok_or_else(|| {
                    format!(
                        "ent_coef '{s}': expected \"auto\", \"auto_<init>\" (e.g. \"auto_0.1\"), a number, \
                         or {{ init = .., target_entropy = .. }}"
                    )
                })?;
                Self::Auto { target_entropy: None, init }
            }
        })
    }
}

impl From<EntCoef> for EntCoefRepr {
    fn from(e: EntCoef) -> Self {
        match e {
            EntCoef::Fixed(v) => Self::Fixed(v),
            EntCoef::Auto { target_entropy: None, init: 1.0 } => Self::Named("auto".into()),
            EntCoef::Auto { target_entropy: None, init } => Self::Named(format!("auto_{init}")),
            EntCoef::Auto { target_entropy, init } => Self::Table { init, target_entropy },
        }
    }
}

/// How the behaviour-cloning term of SAC's actor loss weighs a batch (`bc_form`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BcForm {
    /// Only the demonstration rows: `mean_i(bc_i * mean_j (a~_ij - a_ij)^2)` over the batch.
    #[default]
    PerRow,
    /// The authors' code: the action MSE of the whole batch (every row, the agent's own
    /// transitions too) times the share of demonstration rows, `mean(bc) * mse(a~, a)`.
    Authors,
}

/// Soft Actor-Critic hyperparameters (SB3 `SAC` names and defaults, except `learning_starts`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SacConfig {
    /// Adam learning rate of the actor, the critics and the entropy coefficient.
    pub learning_rate: f64,
    /// Replay buffer capacity in transitions.
    pub buffer_size: usize,
    /// Environment steps of uniformly random actions before learning starts (see module docs).
    pub learning_starts: u64,
    /// Mini-batch size per gradient step.
    pub batch_size: usize,
    /// Polyak coefficient of the target critics: `target <- tau * online + (1 - tau) * target`.
    pub tau: f64,
    /// Discount factor.
    pub gamma: f64,
    /// Environment steps between training phases.
    pub train_freq: u64,
    /// Gradient steps per training phase.
    pub gradient_steps: u64,
    /// Gradient steps between target updates.
    pub target_update_interval: u64,
    /// Entropy coefficient: learned (`"auto"`) or fixed.
    pub ent_coef: EntCoef,
    /// Hidden layer widths of the actor and of each critic (ReLU).
    pub net_arch: Vec<usize>,
    /// Uniformly random actions before `learning_starts` (SB3). `false`: the policy acts from
    /// the first step, and learning starts once the buffer holds a batch (and more than
    /// `learning_starts` steps were taken): the authors' code.
    pub warmup: bool,
    /// Store an episode cut by the time limit as terminal (no bootstrap), as the authors' code
    /// does; `false` bootstraps it (SB3, CleanRL).
    pub terminal_on_truncation: bool,
    /// Before training, every transition of the run's demonstration set goes into the replay
    /// buffer (the authors' code), those of safe demonstrations marked for behaviour cloning.
    pub demos_in_replay: bool,
    /// Weight of the behaviour-cloning term of the actor loss (0: none; the authors' code: 1).
    /// Needs `demos_in_replay`.
    pub bc_weight: f64,
    /// How the behaviour-cloning term weighs a batch.
    pub bc_form: BcForm,
}

impl Default for SacConfig {
    fn default() -> Self {
        Self {
            learning_rate: 3e-4,
            buffer_size: 1_000_000,
            learning_starts: 5_000,
            batch_size: 256,
            tau: 0.005,
            gamma: 0.99,
            train_freq: 1,
            gradient_steps: 1,
            target_update_interval: 1,
            ent_coef: EntCoef::default(),
            net_arch: vec![256, 256],
            warmup: true,
            terminal_on_truncation: false,
            demos_in_replay: false,
            bc_weight: 0.0,
            bc_form: BcForm::default(),
        }
    }
}

/// Twin Delayed DDPG hyperparameters (SB3 `TD3` names and defaults, except `learning_starts`;
/// SB3 has no exploration noise by default, the TD3 paper and the RL Zoo use Gaussian 0.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Td3Config {
    /// Adam learning rate of the actor and the critics.
    pub learning_rate: f64,
    /// Replay buffer capacity in transitions.
    pub buffer_size: usize,
    /// Environment steps of uniformly random actions before learning starts.
    pub learning_starts: u64,
    /// Mini-batch size per gradient step.
    pub batch_size: usize,
    /// Polyak coefficient of the target networks.
    pub tau: f64,
    /// Discount factor.
    pub gamma: f64,
    /// Environment steps between training phases.
    pub train_freq: u64,
    /// Gradient steps per training phase.
    pub gradient_steps: u64,
    /// Critic updates per actor (and target) update.
    pub policy_delay: u64,
    /// Standard deviation of the target policy smoothing noise (normalised action units).
    pub target_policy_noise: f64,
    /// The smoothing noise is clipped to `[-target_noise_clip, target_noise_clip]`.
    pub target_noise_clip: f64,
    /// Standard deviation of the Gaussian exploration noise added to the actor's action during
    /// training (normalised action units; SB3's `NormalActionNoise(0, sigma)`).
    pub exploration_noise: f64,
    /// Hidden layer widths of the actor and of each critic (ReLU).
    pub net_arch: Vec<usize>,
    /// Uniformly random actions before `learning_starts`; `false`: the policy (with its
    /// exploration noise) acts from the first step and learning starts once the buffer holds a
    /// batch (as [`SacConfig::warmup`]).
    pub warmup: bool,
    /// Store an episode cut by the time limit as terminal (as [`SacConfig::terminal_on_truncation`]).
    pub terminal_on_truncation: bool,
    /// Demonstrations in the replay buffer before training (as [`SacConfig::demos_in_replay`];
    /// TD3 has no behaviour-cloning term, as in the authors' code).
    pub demos_in_replay: bool,
}

impl Default for Td3Config {
    fn default() -> Self {
        Self {
            learning_rate: 3e-4,
            buffer_size: 1_000_000,
            learning_starts: 5_000,
            batch_size: 256,
            tau: 0.005,
            gamma: 0.99,
            train_freq: 1,
            gradient_steps: 1,
            policy_delay: 2,
            target_policy_noise: 0.2,
            target_noise_clip: 0.5,
            exploration_noise: 0.1,
            net_arch: vec![256, 256],
            warmup: true,
            terminal_on_truncation: false,
            demos_in_replay: false,
        }
    }
}

fn bad(field: &'static str, value: impl std::fmt::Display, expected: &'static str) -> RlError {
    RlError::Config { field, value: value.to_string(), expected }
}

/// The settings both algorithms share.
struct Common<'a> {
    learning_rate: f64,
    buffer_size: usize,
    batch_size: usize,
    tau: f64,
    gamma: f64,
    train_freq: u64,
    net_arch: &'a [usize],
}

/// The widest hidden layer accepted.
const MAX_LAYER_WIDTH: usize = 1 << 16;
/// The most weights between hidden layers accepted: 1 GB of f32 per network (and SAC keeps
/// about ten copies: actor, two critics, their targets and Adam's moments).
const MAX_HIDDEN_WEIGHTS: usize = 1 << 28;
/// The largest batch accepted: each layer's activations hold batch x width floats, and a batch
/// is allocated when the network is built (a larger one fails there, far from the setting).
pub const MAX_BATCH_SIZE: usize = 1 << 20;

/// Checks hidden layer widths (the agents' `net_arch`, the dynamics model's `hidden`): each at
/// most 65536 units, and at most 2^28 weights between hidden layers, so that a network is built
/// or refused here, never aborted by a failed allocation.
///
/// # Errors
/// [`RlError::Config`] naming `field`.
pub fn check_layers(field: &'static str, widths: &[usize]) -> Result<(), RlError> {
    let hidden_weights =
        widths.windows(2).try_fold(0usize, |sum, w| w[0].checked_mul(w[1]).and_then(|n| sum.checked_add(n)));
    if widths.iter().any(|&w| w > MAX_LAYER_WIDTH) || hidden_weights.is_none_or(|n| n > MAX_HIDDEN_WEIGHTS) {
        return Err(bad(
            field,
            format!("{widths:?}"),
            "layers of at most 65536 units and at most 2^28 weights between hidden layers (1 GB per network)",
        ));
    }
    Ok(())
}

/// Checks a batch size: from 1 to [`MAX_BATCH_SIZE`].
///
/// # Errors
/// [`RlError::Config`] naming `batch_size`.
pub fn check_batch_size(batch_size: usize) -> Result<(), RlError> {
    if batch_size == 0 || batch_size > MAX_BATCH_SIZE {
        return Err(bad("batch_size", batch_size, "from 1 to 2^20 (1048576)"));
    }
    Ok(())
}

/// Checks the settings both algorithms share.
fn check_common(c: Common<'_>) -> Result<(), RlError> {
    let Common { learning_rate, buffer_size, batch_size, tau, gamma, train_freq, net_arch } = c;
    if !(learning_rate.is_finite() && learning_rate > 0.0) {
        return Err(bad("learning_rate", learning_rate, "a finite number > 0"));
    }
    if buffer_size == 0 {
        return Err(bad("buffer_size", buffer_size, "at least 1"));
    }
    check_batch_size(batch_size)?;
    if !(tau > 0.0 && tau <= 1.0) {
        return Err(bad("tau", tau, "in (0, 1]"));
    }
    if !(0.0..=1.0).contains(&gamma) {
        return Err(bad("gamma", gamma, "in [0, 1]"));
    }
    if train_freq == 0 {
        return Err(bad("train_freq", train_freq, "at least 1"));
    }
    if net_arch.is_empty() || net_arch.contains(&0) {
        return Err(bad("net_arch", format!("{net_arch:?}"), "one or more positive layer widths"));
    }
    check_layers("net_arch", net_arch)
}

impl SacConfig {
    /// Checks every value's range.
    ///
    /// # Errors
    /// [`RlError::Config`] naming the first bad field.
    pub fn validate(&self) -> Result<(), RlError> {
        let s = self;
        check_common(Common {
            learning_rate: s.learning_rate,
            buffer_size: s.buffer_size,
            batch_size: s.batch_size,
            tau: s.tau,
            gamma: s.gamma,
            train_freq: s.train_freq,
            net_arch: &s.net_arch,
        })?;
        if s.target_update_interval == 0 {
            return Err(bad("target_update_interval", 0, "at least 1"));
        }
        match s.ent_coef {
            EntCoef::Fixed(v) if !(v.is_finite() && v >= 0.0) => {
                Err(bad("ent_coef", v, "a finite number >= 0, or \"auto\""))
            }
            EntCoef::Auto { init, .. } if !(init.is_finite() && init > 0.0) => {
                Err(bad("ent_coef", init, "an initial value > 0 (\"auto_<init>\")"))
            }
            EntCoef::Auto { target_entropy: Some(t), .. } if !t.is_finite() => {
                Err(bad("ent_coef.target_entropy", t, "a finite number"))
            }
            _ => Ok(()),
        }?;
        if !(s.bc_weight.is_finite() && s.bc_weight >= 0.0) {
            return Err(bad("bc_weight", s.bc_weight, "a finite number >= 0"));
        }
        if s.bc_weight > 0.0 && !s.demos_in_replay {
            return Err(bad(
                "bc_weight",
                s.bc_weight,
                "0 unless demos_in_replay = true (behaviour cloning needs demonstrations in the buffer)",
            ));
        }
        Ok(())
    }
}

impl Td3Config {
    /// Checks every value's range.
    ///
    /// # Errors
    /// [`RlError::Config`] naming the first bad field.
    pub fn validate(&self) -> Result<(), RlError> {
        let s = self;
        check_common(Common {
            learning_rate: s.learning_rate,
            buffer_size: s.buffer_size,
            batch_size: s.batch_size,
            tau: s.tau,
            gamma: s.gamma,
            train_freq: s.train_freq,
            net_arch: &s.net_arch,
        })?;
        if s.policy_delay == 0 {
            return Err(bad("policy_delay", 0, "at least 1"));
        }
        for (field, v) in [
            ("target_policy_noise", s.target_policy_noise),
            ("target_noise_clip", s.target_noise_clip),
            ("exploration_noise", s.exploration_noise),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(field, v, "a finite number >= 0"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_sb3s_and_toml_round_trips() {
        let sac = SacConfig::default();
        assert_eq!((sac.learning_rate, sac.batch_size, sac.buffer_size), (3e-4, 256, 1_000_000));
        assert_eq!((sac.tau, sac.gamma, sac.train_freq, sac.gradient_steps), (0.005, 0.99, 1, 1));
        let text = toml::to_string(&sac).unwrap();
        assert!(text.contains("ent_coef = \"auto\""), "{text}");
        assert_eq!(toml::from_str::<SacConfig>(&text).unwrap(), sac);
        let td3 = Td3Config::default();
        assert_eq!((td3.policy_delay, td3.target_policy_noise, td3.target_noise_clip), (2, 0.2, 0.5));
        assert_eq!(toml::from_str::<Td3Config>(&toml::to_string(&td3).unwrap()).unwrap(), td3);
    }

    #[test]
    fn partial_toml_takes_defaults_and_unknown_keys_are_refused() {
        let c: SacConfig = toml::from_str("learning_starts = 100\nent_coef = 0.2").unwrap();
        assert_eq!(c.learning_starts, 100);
        assert_eq!(c.ent_coef, EntCoef::Fixed(0.2));
        assert_eq!(c.batch_size, 256);
        let c: SacConfig = toml::from_str("ent_coef = \"auto_0.1\"").unwrap();
        assert_eq!(c.ent_coef, EntCoef::Auto { target_entropy: None, init: 0.1 });
        let c: SacConfig = toml::from_str("ent_coef = { target_entropy = -2.0 }").unwrap();
        assert_eq!(c.ent_coef, EntCoef::Auto { target_entropy: Some(-2.0), init: 1.0 });
        assert_eq!(toml::from_str::<SacConfig>(&toml::to_string(&c).unwrap()).unwrap(), c);
        let err = toml::from_str::<SacConfig>("learnin_rate = 1e-3").unwrap_err().to_string();
        assert!(err.contains("learnin_rate"), "{err}");
        assert!(toml::from_str::<SacConfig>("ent_coef = \"automatic\"").is_err());
        assert!(toml::from_str::<Td3Config>("ent_coef = 0.1").is_err());
    }

    #[test]
    fn validation_names_the_field() {
        let c = SacConfig { tau: 1.5, ..SacConfig::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "tau", .. })));
        let c = SacConfig { bc_weight: 1.0, ..SacConfig::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "bc_weight", .. })));
        let c = SacConfig { bc_weight: 1.0, demos_in_replay: true, ..SacConfig::default() };
        assert!(c.validate().is_ok());
        let c = SacConfig { bc_weight: f64::NAN, demos_in_replay: true, ..SacConfig::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "bc_weight", .. })));
        // TD3 has no behaviour-cloning term: the key is refused by name.
        let err = toml::from_str::<Td3Config>("bc_weight = 1.0").unwrap_err().to_string();
        assert!(err.contains("bc_weight"), "{err}");
        let c: SacConfig = toml::from_str("bc_form = \"authors\"").unwrap();
        assert_eq!(c.bc_form, BcForm::Authors);
        let c = Td3Config { net_arch: vec![], ..Td3Config::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "net_arch", .. })));
        assert!(SacConfig::default().validate().is_ok() && Td3Config::default().validate().is_ok());
    }

    /// Sizes that would abort the process when the networks are built are refused by name.
    #[test]
    fn sizes_beyond_memory_are_refused_before_anything_is_built() {
        let c = SacConfig { batch_size: 1 << 62, ..SacConfig::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "batch_size", .. })));
        let c = Td3Config { batch_size: MAX_BATCH_SIZE + 1, ..Td3Config::default() };
        assert!(matches!(c.validate(), Err(RlError::Config { field: "batch_size", .. })));
        assert!(check_batch_size(MAX_BATCH_SIZE).is_ok());
        let err = check_layers("hidden", &[3, 1 << 33]).unwrap_err().to_string();
        assert!(err.contains("hidden = [3, 8589934592]"), "{err}");
        assert!(check_layers("hidden", &[]).is_ok() && check_layers("hidden", &[256, 256]).is_ok());
    }
}
