//! What a report reads from one run besides SPEC section 6's Acc Reward and % Crash: the best
//! training episode (the paper's own "Acc Reward", as its code computes it), the mean of the last
//! evaluations (one final evaluation is noisy), and how often the evaluated agent stood still.
//! The exact definitions are in docs/run-directory.md ("What `defender report` computes").

use crate::run::{EvalRow, Run};

/// How many of a run's last evaluations "Last-10 eval" averages.
pub const LAST_EVALUATIONS: usize = 10;

/// An evaluation stands still when its mean return is within this share of its mean length (and
/// it lasted the horizon): see [`is_standing`].
pub const STANDING_TOLERANCE: f64 = 0.1;

/// The horizon (Gymnasium's `max_episode_steps`) of the tasks `defender train` runs, by
/// Gymnasium id; `None` for another task. defender-mujoco's task registry holds the same numbers
/// (a test in crates/defender-cli/tests/report_cli.rs checks that they agree).
pub fn horizon(env: &str) -> Option<u64> {
    match env {
        "Hopper-v5" | "Walker2d-v5" | "InvertedDoublePendulum-v5" => Some(1000),
        "Hopper-v4" | "Walker2d-v4" | "HalfCheetah-v4" => Some(1000),
        "SafetyHopperVelocity-v1" | "SafetyWalker2dVelocity-v1" | "SafetyHalfCheetahVelocity-v1" => {
            Some(1000)
        }
        "Pendulum-v1" => Some(200),
        _ => None,
    }
}

/// Whether an evaluation shows an agent that stands still: every episode lasted the horizon
/// (`mean_length` = `horizon`, a mean of lengths capped at the horizon) and the mean return is
/// within [`STANDING_TOLERANCE`] of the mean length (`|mean_return - mean_length| <= 0.1 x
/// mean_length`). On Hopper-v5 and Walker2d-v5 the healthy reward alone (1 per step) gives
/// return ~= length; a hopping or walking agent earns several times more. On
/// InvertedDoublePendulum-v5 (~9.3 per step while balanced) it is never true. HalfCheetah has no
/// healthy reward: standing still earns ~0 there, so this measure never flags it.
pub fn is_standing(eval: &EvalRow, horizon: u64) -> bool {
    let length = eval.mean_length;
    length >= horizon as f64 && (eval.mean_return - length).abs() <= STANDING_TOLERANCE * length
}

impl Run {
    /// The best single training-episode return of the run: the maximum of `metrics.csv`'s
    /// `return` over all episodes, filtered ones included (the paper's code reports this as "Acc
    /// Reward"); `None` for a run without a training episode.
    pub fn best_episode(&self) -> Option<f64> {
        self.episodes.iter().map(|e| e.ret).reduce(f64::max)
    }

    /// The mean `mean_return` of the run's last [`LAST_EVALUATIONS`] evaluations (of all of
    /// them when it has fewer; a loaded run has at least one).
    pub fn last_evaluations(&self) -> f64 {
        let start = self.evaluations.len().saturating_sub(LAST_EVALUATIONS);
        let last = &self.evaluations[start..];
        last.iter().map(|e| e.mean_return).sum::<f64>() / last.len() as f64
    }

    /// The share of the run's evaluations (every row of `eval.csv`) that stand still
    /// ([`is_standing`]), in %; `None` when the task's horizon is not known ([`horizon`]).
    pub fn standing_pct(&self) -> Option<f64> {
        let horizon = horizon(&self.config.env)?;
        let n = self.evaluations.len();
        if n == 0 {
            return Some(0.0);
        }
        let standing = self.evaluations.iter().filter(|e| is_standing(e, horizon)).count();
        Some(100.0 * standing as f64 / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(mean_return: f64, mean_length: f64) -> EvalRow {
        EvalRow {
            total_steps: 0,
            mean_return,
            std_return: 0.0,
            mean_length,
            episodes: 10,
            mean_cost: None,
            shield: None,
        }
    }

    #[test]
    fn standing_is_the_horizon_and_a_return_near_the_length() {
        assert!(is_standing(&eval(1000.0, 1000.0), 1000));
        assert!(is_standing(&eval(1100.0, 1000.0), 1000), "10% above: still standing");
        assert!(is_standing(&eval(900.0, 1000.0), 1000), "10% below");
        assert!(!is_standing(&eval(1100.1, 1000.0), 1000));
        assert!(!is_standing(&eval(899.9, 1000.0), 1000));
        assert!(!is_standing(&eval(3000.0, 1000.0), 1000), "hopping");
        assert!(!is_standing(&eval(9350.0, 1000.0), 1000), "a balanced double pendulum");
        assert!(!is_standing(&eval(990.0, 999.9), 1000), "one episode ended before the horizon");
        assert!(!is_standing(&eval(200.0, 200.0), 1000));
        assert!(is_standing(&eval(200.0, 200.0), 200));
        assert_eq!(horizon("Hopper-v5"), Some(1000));
        assert_eq!(horizon("CartPole-v1"), None);
    }
}
