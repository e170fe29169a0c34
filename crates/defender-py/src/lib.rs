//! `defender_rl._core`: the Rust half of the `defender-rl` Python package (docs/python.md).
//!
//! Everything DEFENDER decides is decided here, by the workspace's own code: the Gymnasium
//! wrapper's core drives a [`defender::DefenderEnv`] whose inner environment is the Python
//! environment (see [`env`]), so a Python user runs the very code path of `defender train`. The
//! pure-Python package (`python/defender_rl`) adds the `gymnasium.Wrapper` subclass, the Minari
//! import, demonstration recording and the Stable-Baselines3 callback around these classes.
//!
//! Errors: every fallible call returns a Python exception whose message names what is wrong
//! (`DefenderError`, a `ValueError`, for bad input; `OSError` for files; the wrapped
//! environment's own exception unchanged). Rust panics are caught at the boundary and turned
//! into a `RuntimeError` (they would be bugs).

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod arrays;
mod checks;
mod costs;
mod env;
mod episodes;
mod interrupt;
mod select;
mod step_cost;
mod turn;

// Named as the package exports them (`defender_rl.DefenderError`), not as the extension module
// that defines them: pickle finds a class by its module and name, and `_core` is not importable
// on its own, so an error raised in a vector environment's worker process could not be sent back
// (the parent would wait forever).
create_exception!(
    defender_rl,
    DefenderError,
    PyValueError,
    "Bad input to DEFENDER (demonstrations, strategy, dimensions, values, configuration); the message says what to fix."
);
create_exception!(
    defender_rl,
    ResetNeeded,
    PyRuntimeError,
    "step() was called before reset(), or after the episode ended."
);

/// Converts the library's errors into Python exceptions.
pub(crate) fn defender_err(e: defender::DefenderError) -> PyErr {
    match e {
        defender::DefenderError::Io { .. } => PyOSError::new_err(e.to_string()),
        defender::DefenderError::Env(e) => env_err(e),
        other => DefenderError::new_err(other.to_string()),
    }
}

/// Converts an environment error into a Python exception.
pub(crate) fn env_err(e: defender_rl::EnvError) -> PyErr {
    match e {
        defender_rl::EnvError::NeedsReset => ResetNeeded::new_err(
            "step() called on an episode that has ended or not started: call reset() first",
        ),
        defender_rl::EnvError::State { .. } => PyOSError::new_err(e.to_string()),
        other => DefenderError::new_err(other.to_string()),
    }
}

/// Runs `f`, turning a Rust panic into a Python `RuntimeError` (a panic is a bug: never let it
/// cross into Python as `PanicException`).
pub(crate) fn guard<T>(what: &str, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!("internal error in {what} (please report): {msg}")))
        }
    }
}

/// `derive_seed(seed, purpose, index)`: the seed `defender train` / `defender demos collect`
/// use for `purpose` (`init`, `agent`, `train_episode`, `eval_episode`, `wrapper`,
/// `demonstration`) and `index`, so that Python code can seed as the Rust tools do.
#[pyfunction]
fn derive_seed(seed: u64, purpose: &str, index: u64) -> PyResult<u64> {
    use defender_rl::SeedPurpose::*;
    let p = match purpose {
        "init" => Init,
        "agent" => Agent,
        "train_episode" => TrainEpisode,
        "eval_episode" => EvalEpisode,
        "wrapper" => Wrapper,
        "demonstration" => Demonstration,
        other => {
            return Err(DefenderError::new_err(format!(
                "derive_seed: unknown purpose '{other}'; one of init, agent, train_episode, eval_episode, wrapper, demonstration"
            )));
        }
    };
    Ok(defender_rl::derive_seed(seed, p, index))
}

/// `profile_filter(name)`: the `[defender.filter]` settings (JSON) a profile gives a DEFENDER
/// run (`DefenderWrapper(profile=...)`), from the same definition `defender train --profile`
/// uses; `{}` for `spec`. `authors` changes the cost, which the wrapper does not take.
#[pyfunction]
fn profile_filter(name: &str) -> PyResult<String> {
    let filter = match name {
        "spec" => defender::FilterOptions::default(),
        "keeps-learning" => defender::FilterOptions::keeps_learning(),
        other => {
            return Err(DefenderError::new_err(format!(
                "profile = '{other}': the wrapper knows 'spec' and 'keeps-learning' (the authors' profile \
                 changes the DTW cost and the learner: `defender train --profile authors`)"
            )));
        }
    };
    if filter.is_spec() {
        return Ok("{}".into());
    }
    serde_json::to_string(&filter).map_err(|e| DefenderError::new_err(e.to_string()))
}

/// The extension module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("DefenderError", py.get_type::<DefenderError>())?;
    m.add("ResetNeeded", py.get_type::<ResetNeeded>())?;
    m.add_class::<episodes::EpisodeSet>()?;
    m.add_class::<env::Core>()?;
    m.add_function(wrap_pyfunction!(costs::dtw, m)?)?;
    m.add_function(wrap_pyfunction!(costs::window_cost, m)?)?;
    m.add_function(wrap_pyfunction!(costs::group_cost, m)?)?;
    m.add_function(wrap_pyfunction!(costs::trajectory_costs, m)?)?;
    m.add_function(wrap_pyfunction!(costs::ablate, m)?)?;
    m.add_function(wrap_pyfunction!(costs::strategies, m)?)?;
    m.add_function(wrap_pyfunction!(select::select_strategies, m)?)?;
    m.add_function(wrap_pyfunction!(derive_seed, m)?)?;
    m.add_function(wrap_pyfunction!(profile_filter, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
