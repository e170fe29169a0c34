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

/// The `margin` trigger as a shield: a step is allowed while the state's failure proximity
/// stays at or below the threshold (`1 - task_margin`). It reads the proximity from a copy of
/// the task, whose simulator it never steps.
pub struct MarginShield {
    task: Box<dyn defender_rl::Env>,
    threshold: f64,
}

impl MarginShield {
    /// The shield of a `margin` trigger over `task` (any copy of the task: only its failure
    /// condition is read).
    pub fn new(task: Box<dyn defender_rl::Env>, threshold: f64) -> Self {
        Self { task, threshold }
    }
}

impl Shield for MarginShield {
    fn reset(&mut self) {}

    fn allows(&mut self, obs: &[f64], _action: &[f64]) -> defender_rl::Result<bool> {
        Ok(self.task.failure_proximity(obs).is_none_or(|p| p <= self.threshold))
    }
}

/// The `classifier` trigger as a shield: a copy of the classifier as it stood, allowing a step
/// while its probability stays at or below the threshold.
#[derive(Debug, Clone)]
pub struct ClassifierShield {
    classifier: crate::classifier::Classifier,
}

impl ClassifierShield {
    /// The shield that decides as `classifier` (a copy of it).
    pub fn new(classifier: crate::classifier::Classifier) -> Self {
        Self { classifier }
    }
}

impl Shield for ClassifierShield {
    fn reset(&mut self) {
        self.classifier.begin();
    }

    fn allows(&mut self, obs: &[f64], action: &[f64]) -> defender_rl::Result<bool> {
        let threshold = self.classifier.options().threshold;
        match self.classifier.push(obs, action) {
            Ok(p) => Ok(p <= threshold),
            Err(e) => Err(EnvError::Simulator(format!("DEFENDER's shield: {e}"))),
        }
    }
}
