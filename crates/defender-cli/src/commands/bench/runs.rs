//! The training runs the figures compare: bare SAC or TD3, or SAC on `DefenderEnv` with a given
//! strategy, mode and dynamics-model schedule.

use defender::{DynamicsConfig, Mode, Strategy};
use defender_rl::Algo;

// Training runs.

/// The dynamics model's schedule in a DEFENDER run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Schedule {
    /// SPEC's: one gradient step on a batch of 256 per real step.
    Default,
    /// Never trained (`train_freq` = 10^9): the filter and the wrapper alone.
    Untrained,
    /// One gradient step every `k` real steps.
    Every(usize),
    /// One gradient step per real step on a smaller batch.
    Batch(usize),
    /// SPEC's, trained on the model's own thread while the agent updates.
    Background,
}

impl Schedule {
    pub(super) fn config(self) -> DynamicsConfig {
        let d = DynamicsConfig::default();
        match self {
            Schedule::Default => d,
            Schedule::Untrained => DynamicsConfig { train_freq: 1_000_000_000, ..d },
            Schedule::Every(k) => DynamicsConfig { train_freq: k, ..d },
            Schedule::Batch(b) => DynamicsConfig { batch_size: b, ..d },
            Schedule::Background => DynamicsConfig { background: true, ..d },
        }
    }
    pub(super) fn text(self) -> String {
        match self {
            Schedule::Default => "dynamics model as SPEC".into(),
            Schedule::Untrained => "dynamics model not trained".into(),
            Schedule::Every(k) => format!("dynamics model trained every {k} steps"),
            Schedule::Batch(b) => format!("dynamics model batch {b}"),
            Schedule::Background => "dynamics model as SPEC, on its own thread".into(),
        }
    }
}

/// A training run: bare SAC or TD3, or SAC on `DefenderEnv`.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum RunKind {
    Bare(Algo),
    Defender { strategy: Strategy, mode: Mode, schedule: Schedule },
}
