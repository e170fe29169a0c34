//! The safety cost of a step of the wrapped Python environment (docs/SPEC.md, section 12):
//! `DefenderWrapper(cost_key=...)` reads it from the step's `info` dict (safety-gymnasium's
//! Gymnasium-API conversion puts it under `"cost"`), else it is the crash rule the CLI applies
//! on the crash tasks: 1 on a step that terminated the episode, 0 otherwise.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::DefenderError;

/// Where a step's cost comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum CostSource {
    /// `info[key]`. A step whose `info` lacks the key costs by the crash rule, unless the user
    /// named the key (`required`): then a missing key is a mistake (a typo, the wrong
    /// environment) that would otherwise pass silently as "no violation", so it raises.
    Info { key: String, required: bool },
    /// The crash rule alone (`cost_key=None`).
    Crash,
}

impl CostSource {
    /// `key`: `cost_key` (None: the crash rule); `required`: the user passed it explicitly.
    pub(crate) fn new(key: Option<String>, required: bool) -> Self {
        match key {
            Some(key) => CostSource::Info { key, required },
            None => CostSource::Crash,
        }
    }

    /// The cost of a step of the wrapped environment that returned `info` and ended
    /// `terminated`; `at` says where ("at step N of the episode") for error messages.
    pub(crate) fn of_step(
        &self,
        info: &Bound<'_, PyAny>,
        terminated: bool,
        at: &dyn Fn() -> String,
    ) -> PyResult<f64> {
        let CostSource::Info { key, required } = self else { return Ok(crash_rule(terminated)) };
        let dict = info.cast::<PyDict>().ok();
        let value = match dict.map(|d| d.get_item(key)).transpose()?.flatten() {
            Some(v) => v,
            None if *required => {
                let keys = match dict {
                    Some(d) => d.keys().repr()?.to_string(),
                    None => format!("none: it is a {}, not a dict", info.get_type().name()?),
                };
                return Err(DefenderError::new_err(format!(
                    "DefenderWrapper(cost_key={key:?}): the wrapped environment's step() returned an info \
                     without the key {key:?} {} (its keys: {keys}); pass the key under which the \
                     environment's info carries the step's cost, or cost_key=None for the crash rule \
                     (a step that terminates the episode costs 1)",
                    at()
                )));
            }
            None => return Ok(crash_rule(terminated)),
        };
        let where_ = || {
            format!(
                "DefenderWrapper: the cost info[{key:?}] (cost_key) returned by the wrapped environment's step() {}",
                at()
            )
        };
        let cost: f64 = value.extract().map_err(|_| {
            let shown = value.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
            PyTypeError::new_err(format!("{} is not a number: {shown}", where_()))
        })?;
        if !(cost.is_finite() && cost >= 0.0) {
            return Err(DefenderError::new_err(format!(
                "{} is {cost}; a cost must be a finite number >= 0",
                where_()
            )));
        }
        Ok(cost)
    }
}

/// The crash tasks' rule (defender-mujoco's `Cost::Crash`): a step that terminated the episode
/// costs 1, any other 0.
fn crash_rule(terminated: bool) -> f64 {
    if terminated { 1.0 } else { 0.0 }
}
