//! The training runs the figures compare: bare SAC or TD3, or SAC on `DefenderEnv` with a given
//! strategy, mode and dynamics-model schedule.

use defender::{DynamicsConfig, Mode, Strategy};
use defender_rl::{Algo, Parallelism};

use crate::setup::model_on_own_thread;

// Training runs.

/// The dynamics model's schedule in a DEFENDER run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Schedule {
    /// The default, where `defender train` runs it: `DynamicsConfig::default()`, on the model's
    /// own thread when the networks have two or more ([`model_on_own_thread`]).
    Default,
    /// The default on the calling thread.
    DefaultInline,
    /// SPEC section 5's: one gradient step on a batch of 256 per real step.
    Spec,
    /// Never trained (`train_freq` = 10^9): the filter and the wrapper alone.
    Untrained,
    /// SPEC's, trained on the model's own thread while the agent updates.
    SpecBackground,
}

impl Schedule {
    /// The model's configuration in a run whose networks use `par`.
    pub(super) fn config(self, par: Parallelism) -> DynamicsConfig {
        let spec = DynamicsConfig::spec_schedule();
        match self {
            Schedule::Default => {
                DynamicsConfig { background: model_on_own_thread(false, par), ..DynamicsConfig::default() }
            }
            Schedule::DefaultInline => DynamicsConfig::default(),
            Schedule::Spec => spec,
            Schedule::Untrained => DynamicsConfig { train_freq: 1_000_000_000, ..spec },
            Schedule::SpecBackground => DynamicsConfig { background: true, ..spec },
        }
    }
    pub(super) fn text(self) -> String {
        let d = DynamicsConfig::default();
        match self {
            Schedule::Default => format!(
                "dynamics model as default ({} step(s) of batch {} every {} real steps)",
                d.gradient_steps, d.batch_size, d.train_freq
            ),
            Schedule::Spec => "dynamics model as SPEC (batch 256 every real step)".into(),
            Schedule::Untrained => "dynamics model not trained".into(),
            Schedule::SpecBackground => "dynamics model as SPEC, on its own thread".into(),
            Schedule::DefaultInline => "dynamics model as default, on the calling thread".into(),
        }
    }
}

/// A training run: bare SAC or TD3, or SAC on `DefenderEnv`.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum RunKind {
    Bare(Algo),
    Defender { strategy: Strategy, mode: Mode, schedule: Schedule },
}
