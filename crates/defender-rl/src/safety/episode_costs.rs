//! `J_c`, the quantity both Lagrangian controllers drive towards the limit: the mean cost of the
//! last `window` finished training episodes, with the cost of the episode under way.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// The costs of the last `window` finished training episodes and of the one under way. State a
/// checkpoint keeps (its JSON fields sit in the controller's own object).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct EpisodeCosts {
    /// How many finished episodes `J_c` averages.
    window: usize,
    /// Their costs, oldest first.
    costs: VecDeque<f64>,
    /// The cost of the episode under way so far.
    running: f64,
}

impl EpisodeCosts {
    /// No episode seen.
    pub(crate) fn new(window: usize) -> Self {
        Self { window, costs: VecDeque::with_capacity(window), running: 0.0 }
    }

    /// Adds one step's `cost`; at an episode's end (`episode_end`) the episode joins the window.
    /// Returns whether an episode ended.
    pub(crate) fn observe(&mut self, cost: f64, episode_end: bool) -> bool {
        self.running += cost;
        if !episode_end {
            return false;
        }
        if self.costs.len() == self.window {
            self.costs.pop_front();
        }
        self.costs.push_back(self.running);
        self.running = 0.0;
        true
    }

    /// `J_c` (`None` before the first finished episode).
    pub(crate) fn mean(&self) -> Option<f64> {
        (!self.costs.is_empty()).then(|| self.costs.iter().sum::<f64>() / self.costs.len() as f64)
    }
}
