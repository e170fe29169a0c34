//! The flag by which Recovery RL's safety critic, living in the agent, tells a DEFENDER
//! environment to end the episode (the `risk-critic` trigger, docs/SPEC.md section 15): the agent
//! raises it when it proposes an exploration action with `Q_risk(s, a) > eps_risk`, and the
//! environment takes it down when that action reaches it. Both hold a clone.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared flag: raised (or lowered) by the agent for the action it just proposed, taken by the
/// environment at the step that receives the action.
#[derive(Debug, Clone, Default)]
pub struct RiskSignal(Arc<AtomicBool>);

impl RiskSignal {
    /// A lowered flag.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the flag for the action just proposed.
    pub fn set(&self, risky: bool) {
        self.0.store(risky, Ordering::SeqCst);
    }

    /// Reads and lowers the flag.
    pub fn take(&self) -> bool {
        self.0.swap(false, Ordering::SeqCst)
    }
}
