//! DEFENDER's filter as a shield: what a `DefenderEnv` lends the trainer so that each evaluation
//! also runs with the filter kept, as it would be deployed (docs/SPEC.md, section 6;
//! `defender_rl::Env::shield`).

use defender_rl::{EnvError, Shield};

use crate::filter::Filter;

/// A copy of a [`Filter`] as it stood when the copy was made: its demonstrations (with any own
/// episodes that joined them), its margin and its trajectory mode (state or state-action). It
/// decides as the filter does (SPEC section 4) and changes nothing of the filter it was copied
/// from.
#[derive(Debug, Clone)]
pub struct FilterShield {
    filter: Filter,
}

impl FilterShield {
    /// The shield that decides as `filter` (a copy of it).
    pub fn new(filter: Filter) -> Self {
        Self { filter }
    }

    /// The filter it decides with.
    pub fn filter(&self) -> &Filter {
        &self.filter
    }
}

impl Shield for FilterShield {
    fn reset(&mut self) {
        self.filter.reset();
    }

    /// [`Filter::push`]: the step is allowed iff the filter executes it.
    fn allows(&mut self, obs: &[f64], action: &[f64]) -> defender_rl::Result<bool> {
        match self.filter.push(obs, action) {
            Ok(decision) => Ok(!decision.filtered),
            Err(e) => Err(EnvError::Simulator(format!("DEFENDER's shield: {e}"))),
        }
    }
}
