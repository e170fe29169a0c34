//! Gymnasium's `TimeLimit` wrapper.

use crate::env::{Env, Step};
use crate::error::Result;
use crate::space::BoxSpace;

/// Truncates episodes at `max_episode_steps` (1000 for the MuJoCo tasks). A step that both
/// terminates and reaches the limit is reported as terminated and truncated, as in Gymnasium.
#[derive(Debug, Clone)]
pub struct TimeLimit<E> {
    inner: E,
    max_episode_steps: usize,
    elapsed: usize,
}

impl<E: Env> TimeLimit<E> {
    /// Wraps `inner` with a horizon of `max_episode_steps` steps.
    pub fn new(inner: E, max_episode_steps: usize) -> Self {
        Self { inner, max_episode_steps, elapsed: 0 }
    }

    /// Steps taken in the current episode.
    pub fn elapsed_steps(&self) -> usize {
        self.elapsed
    }

    /// The wrapped environment.
    pub fn inner(&self) -> &E {
        &self.inner
    }

    /// The wrapped environment, mutably.
    pub fn inner_mut(&mut self) -> &mut E {
        &mut self.inner
    }

    /// Unwraps.
    pub fn into_inner(self) -> E {
        self.inner
    }
}

impl<E: Env> Env for TimeLimit<E> {
    fn id(&self) -> &str {
        self.inner.id()
    }
    fn observation_space(&self) -> &BoxSpace {
        self.inner.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.inner.action_space()
    }
    fn max_episode_steps(&self) -> Option<usize> {
        Some(self.max_episode_steps)
    }
    fn reset(&mut self, seed: Option<u64>) -> Result<Vec<f64>> {
        self.elapsed = 0;
        self.inner.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> Result<Step> {
        let mut step = self.inner.step(action)?;
        self.elapsed += 1;
        if self.elapsed >= self.max_episode_steps {
            step.truncated = true;
        }
        Ok(step)
    }
    fn save_state(&self, dir: &std::path::Path) -> Result<()> {
        self.inner.save_state(dir)
    }
    fn load_state(&mut self, dir: &std::path::Path) -> Result<()> {
        self.inner.load_state(dir)
    }
    fn shield(&self) -> Option<Box<dyn crate::Shield>> {
        self.inner.shield()
    }
    /// The inner copy under the same horizon, with the steps already taken.
    fn fork(&self) -> Option<Box<dyn Env>> {
        let inner = self.inner.fork()?;
        Some(Box::new(TimeLimit { inner, max_episode_steps: self.max_episode_steps, elapsed: self.elapsed }))
    }
    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        self.inner.failure_proximity(obs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::StepInfo;

    /// A counter environment: observation is the step count; never terminates.
    struct Counter {
        space: BoxSpace,
        t: f64,
    }

    impl Env for Counter {
        fn id(&self) -> &str {
            "Counter"
        }
        fn observation_space(&self) -> &BoxSpace {
            &self.space
        }
        fn action_space(&self) -> &BoxSpace {
            &self.space
        }
        fn reset(&mut self, _seed: Option<u64>) -> Result<Vec<f64>> {
            self.t = 0.0;
            Ok(vec![self.t])
        }
        fn step(&mut self, action: &[f64]) -> Result<Step> {
            self.space.check("action", action)?;
            self.t += 1.0;
            Ok(Step {
                obs: vec![self.t],
                reward: 1.0,
                cost: 0.0,
                terminated: false,
                truncated: false,
                info: StepInfo::default(),
            })
        }
    }

    #[test]
    fn truncates_at_the_horizon_and_resets_the_count() {
        let space = BoxSpace::new(vec![-1.0], vec![1.0]).unwrap();
        let mut env = TimeLimit::new(Counter { space, t: 0.0 }, 3);
        for _ in 0..2 {
            env.reset(None).unwrap();
            assert!(!env.step(&[0.0]).unwrap().truncated);
            assert!(!env.step(&[0.0]).unwrap().truncated);
            let last = env.step(&[0.0]).unwrap();
            assert!(last.truncated && !last.terminated && last.done());
        }
        assert_eq!(env.max_episode_steps(), Some(3));
    }

    #[test]
    fn rejects_bad_actions() {
        let space = BoxSpace::new(vec![-1.0], vec![1.0]).unwrap();
        let mut env = TimeLimit::new(Counter { space, t: 0.0 }, 3);
        env.reset(Some(0)).unwrap();
        assert!(matches!(env.step(&[0.0, 1.0]), Err(crate::EnvError::LengthMismatch { .. })));
        assert!(matches!(env.step(&[f64::NAN]), Err(crate::EnvError::NonFinite { .. })));
    }
}
