//! [`Cost`]: what makes a step of a task cost 1 (the substrate's `Step::cost`), and the episode
//! cost limit the field holds a task's runs to.

/// The episode cost limit of Safety-Gymnasium's velocity tasks: the `cost_limit: 25` of
/// OmniSafe's benchmark configurations (SACLag, PPOLag and the others on `Safety*Velocity-v1`),
/// the number the field's published costs are read against. An episode whose summed cost exceeds
/// it broke the constraint.
pub const EPISODE_COST_LIMIT: f64 = 25.0;

/// The per-step cost rule of a task. A cost is 0 or 1 for every rule.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Cost {
    /// 1 on the step where the task terminates the episode (a fall), the v5 tasks' safety signal.
    Crash,
    /// Safety-Gymnasium's velocity constraint (safety-gymnasium 1.0.0,
    /// `tasks/safe_velocity/safety_*_velocity_v0.py`): 1 when the signed x-velocity
    /// `(x_after - x_before) / dt` of the step is strictly greater than `threshold`
    /// (`float(x_velocity > self._velocity_threshold)`), else 0. A fall is not a cost.
    Velocity {
        /// The v1 threshold (Hopper 0.7402, Walker2d 2.3415, HalfCheetah 3.2096).
        threshold: f64,
    },
    /// No cost: Gymnasium's plain v4 tasks, kept as the velocity tasks' exact bases.
    None,
}

impl Cost {
    /// The cost of a step that ended `terminated` after moving at `x_velocity` (m/s along x).
    pub fn of_step(self, terminated: bool, x_velocity: f64) -> f64 {
        let costly = match self {
            Cost::Crash => terminated,
            Cost::Velocity { threshold } => x_velocity > threshold,
            Cost::None => false,
        };
        if costly { 1.0 } else { 0.0 }
    }

    /// The cost of a step where MuJoCo became unstable (the episode ends, terminated). A crash
    /// task counts it as the crash it is; a velocity task counts it too, because the step's
    /// velocity is meaningless (MuJoCo reset its state) and an unsafe step must never look safe.
    pub fn of_unstable_step(self) -> f64 {
        match self {
            Cost::Crash | Cost::Velocity { .. } => 1.0,
            Cost::None => 0.0,
        }
    }

    /// The episode cost limit runs of a task with this rule are held to: [`EPISODE_COST_LIMIT`]
    /// for the velocity rule; `None` for a crash task (its cost is at most 1 per episode, so the
    /// field counts crashes instead) and for a task without cost.
    pub fn episode_limit(self) -> Option<f64> {
        match self {
            Cost::Velocity { .. } => Some(EPISODE_COST_LIMIT),
            Cost::Crash | Cost::None => None,
        }
    }

    /// The threshold of a velocity rule, `None` for the others.
    pub fn threshold(self) -> Option<f64> {
        match self {
            Cost::Velocity { threshold } => Some(threshold),
            Cost::Crash | Cost::None => None,
        }
    }
}

/// `crash`, `velocity > 0.7402` or `none`: the rule as `defender env list` shows it.
impl std::fmt::Display for Cost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Cost::Crash => f.write_str("crash"),
            Cost::Velocity { threshold } => write!(f, "velocity > {threshold}"),
            Cost::None => f.write_str("none"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_is_strictly_above_the_threshold_and_ignores_falls() {
        let rule = Cost::Velocity { threshold: 0.7402 };
        assert_eq!(rule.of_step(false, 0.7403), 1.0);
        assert_eq!(rule.of_step(false, 0.7402), 0.0, "safety-gymnasium compares with >");
        assert_eq!(rule.of_step(true, 0.0), 0.0, "a fall is not a velocity cost");
        assert_eq!(rule.of_step(true, 5.0), 1.0);
        assert_eq!(rule.of_step(false, -5.0), 0.0, "signed velocity: running backwards is free");
        assert_eq!(rule.to_string(), "velocity > 0.7402");
    }

    #[test]
    fn crash_costs_the_terminal_step_and_none_costs_nothing() {
        assert_eq!(Cost::Crash.of_step(true, 0.0), 1.0);
        assert_eq!(Cost::Crash.of_step(false, 100.0), 0.0);
        assert_eq!(Cost::None.of_step(true, 100.0), 0.0);
        assert_eq!(Cost::None.of_unstable_step(), 0.0);
        assert_eq!((Cost::Crash.to_string(), Cost::None.to_string()), ("crash".into(), "none".into()));
    }

    #[test]
    fn only_the_velocity_rule_has_an_episode_limit() {
        assert_eq!(Cost::Velocity { threshold: 0.7402 }.episode_limit(), Some(25.0));
        assert_eq!(Cost::Crash.episode_limit(), None);
        assert_eq!(Cost::None.episode_limit(), None);
    }
}
