//! DEFENDER's alignment costs as a run goes, for its TensorBoard scalars: the training
//! environment is wrapped so that each step's `Safe(tau)` and `Unsafe(tau)` (the filter's
//! decision, which the trainer's hooks do not see) are summed into a window the hooks read and
//! clear every `update_log::EVERY` steps. Two additions and a lock per step, against a DTW
//! distance per demonstration.

use std::path::Path;
use std::sync::{Arc, Mutex, PoisonError};

use defender::DefenderEnv;
use defender_rl::{BoxSpace, Env, Step};

/// The sums of a window of steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CostWindow {
    /// Steps in the window.
    pub steps: u64,
    /// Sum of `Safe(tau)` over them (finite values only).
    pub safe: f64,
    /// Sum of `Unsafe(tau)` over them (finite values only).
    pub unsafe_: f64,
    /// Steps whose costs were both finite.
    pub finite: u64,
    /// Filtered steps.
    pub filtered: u64,
}

impl CostWindow {
    /// The mean safe cost, mean unsafe cost and fraction of filtered steps of the window, or
    /// `None` for an empty window.
    pub fn means(&self) -> Option<(f64, f64, f64)> {
        if self.steps == 0 {
            return None;
        }
        let n = self.finite.max(1) as f64;
        let (safe, unsafe_) =
            if self.finite == 0 { (f64::NAN, f64::NAN) } else { (self.safe / n, self.unsafe_ / n) };
        Some((safe, unsafe_, self.filtered as f64 / self.steps as f64))
    }
}

/// The window shared between the environment and the hooks.
pub type SharedCosts = Arc<Mutex<CostWindow>>;

/// Takes the window's sums and starts a new one.
pub fn take(costs: &SharedCosts) -> CostWindow {
    std::mem::take(&mut *costs.lock().unwrap_or_else(PoisonError::into_inner))
}

/// Puts back a window (a resumed run's, from its checkpoint).
pub fn restore(costs: &SharedCosts, window: CostWindow) {
    *costs.lock().unwrap_or_else(PoisonError::into_inner) = window;
}

/// A DEFENDER environment that adds each step's costs to a shared window.
pub struct CostMeter<E> {
    inner: DefenderEnv<E>,
    costs: SharedCosts,
}

impl<E: Env> CostMeter<E> {
    /// Wraps `inner`; the returned window is the one to read.
    pub fn new(inner: DefenderEnv<E>) -> (Self, SharedCosts) {
        let costs = SharedCosts::default();
        (Self { inner, costs: costs.clone() }, costs)
    }
}

impl<E: Env> Env for CostMeter<E> {
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
        self.inner.max_episode_steps()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.inner.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let step = self.inner.step(action)?;
        if let Some(d) = self.inner.last_decision() {
            let mut w = self.costs.lock().unwrap_or_else(PoisonError::into_inner);
            w.steps += 1;
            w.filtered += u64::from(d.filtered);
            if d.safe_cost.is_finite() && d.unsafe_cost.is_finite() {
                w.finite += 1;
                w.safe += d.safe_cost;
                w.unsafe_ += d.unsafe_cost;
            }
        }
        Ok(step)
    }
    fn save_state(&self, dir: &Path) -> defender_rl::Result<()> {
        self.inner.save_state(dir)
    }
    fn load_state(&mut self, dir: &Path) -> defender_rl::Result<()> {
        self.inner.load_state(dir)
    }
    fn shield(&self) -> Option<Box<dyn defender_rl::Shield>> {
        self.inner.shield()
    }
    fn fork(&self) -> Option<Box<dyn Env>> {
        self.inner.fork()
    }
    fn failure_proximity(&self, obs: &[f64]) -> Option<f64> {
        self.inner.failure_proximity(obs)
    }
}
