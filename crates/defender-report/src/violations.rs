//! Violations as the safe-RL field counts them, beside the paper's % Crash (crashed / all
//! training episodes), which the filter dilutes: the episodes it ends itself join the
//! denominator. These count over the run's budget instead: crashes, crashes per 1,000
//! environment steps, and the cost rate (Safety Gym's measure of safe exploration: total cost /
//! environment steps of training). A filtered step never reaches the environment, so it is not an
//! environment step: `env_steps = steps - filtered_steps` (docs/run-directory.md).

use serde::{Deserialize, Serialize};

/// A run's violations (`summary.json`, and what `defender report` computes from `metrics.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Violations {
    /// Crashed training episodes.
    #[serde(default)]
    pub crashes: u64,
    /// Training steps that reached the environment: all steps but the filtered ones.
    #[serde(default)]
    pub env_steps: u64,
    /// `crashes / env_steps x 1000`.
    #[serde(default)]
    pub crashes_per_1k_env_steps: f64,
    /// The training episodes' summed cost (on the crash tasks, their crashes).
    #[serde(default)]
    pub cost: f64,
    /// `cost / env_steps`.
    #[serde(default)]
    pub cost_rate: f64,
}

impl Violations {
    /// From the counts of a run of `steps` training steps, `filtered_steps` of them filtered.
    pub fn new(crashes: u64, cost: f64, steps: u64, filtered_steps: u64) -> Self {
        let env_steps = steps.saturating_sub(filtered_steps);
        let per = |x: f64| if env_steps == 0 { 0.0 } else { x / env_steps as f64 };
        Self {
            crashes,
            env_steps,
            crashes_per_1k_env_steps: 1000.0 * per(crashes as f64),
            cost,
            cost_rate: per(cost),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filtered_steps_are_not_environment_steps() {
        let v = Violations::new(5, 5.0, 10_100, 100);
        assert_eq!(v.env_steps, 10_000);
        assert_eq!(v.crashes_per_1k_env_steps, 0.5);
        assert_eq!(v.cost_rate, 0.0005);
        assert_eq!(Violations::new(0, 0.0, 10, 10).crashes_per_1k_env_steps, 0.0);
    }
}
