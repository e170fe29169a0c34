//! Input checks shared by the functions and classes of the extension: names (strategies, methods,
//! windows, modes), required dict keys, and the arrays of trajectories and sequences, each with
//! one error message that names the argument and says what was expected.

use std::str::FromStr;

use defender::{CostOptions, Mode, Scaling, Strategy};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::DefenderError;
use crate::arrays::{read_1d, read_mat_f32};

/// Parses a strategy, method, window or mode name, `what` naming the argument in the error.
pub(crate) fn parse_name<T: FromStr<Err = defender::DefenderError>>(s: &str, what: &str) -> PyResult<T> {
    s.parse::<T>().map_err(|e| DefenderError::new_err(format!("{what}: {e}")))
}

/// `mode`: `"state"` or `"state-action"`.
/// An optional list of strategy names (`None`: all of them; an empty list is refused).
pub(crate) fn parse_strategies(names: Option<Vec<String>>) -> PyResult<Option<Vec<Strategy>>> {
    let list = names
        .map(|l| l.iter().map(|s| parse_name(s, "strategies")).collect::<PyResult<Vec<_>>>())
        .transpose()?;
    if list.as_ref().is_some_and(Vec::is_empty) {
        return Err(DefenderError::new_err("strategies: an empty list (give None for all of them)"));
    }
    Ok(list)
}

/// A ranked table's row as a dict, started with the columns every table has: `rank`, `strategy`,
/// its `safe` and `unsafe` methods and `mode`.
pub(crate) fn strategy_row<'py>(
    py: Python<'py>,
    rank: usize,
    strategy: &Strategy,
    mode: Mode,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("rank", rank)?;
    d.set_item("strategy", strategy.to_string())?;
    d.set_item("safe", strategy.safe.to_string())?;
    d.set_item("unsafe", strategy.unsafe_.to_string())?;
    d.set_item("mode", mode.to_string())?;
    Ok(d)
}

pub(crate) fn parse_mode(s: &str) -> PyResult<Mode> {
    parse_name(s, "mode")
}

/// The alignment cost's options from `scaling`: `"none"` (SPEC section 2's plain DTW) or
/// `"zscore"` (per feature, fitted on the demonstrations), as a run's `[defender.cost] scaling`.
pub(crate) fn parse_cost(scaling: &str) -> PyResult<CostOptions> {
    let scaling: Scaling = scaling.parse().map_err(|_| {
        DefenderError::new_err(format!(
            "scaling: unknown '{scaling}'; expected 'none' (plain DTW) or 'zscore'"
        ))
    })?;
    Ok(CostOptions { scaling })
}

/// `d[key]`, or an error naming `what` and the missing key.
pub(crate) fn required_item<'py>(
    d: &Bound<'py, PyDict>,
    key: &str,
    what: &str,
) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?.ok_or_else(|| DefenderError::new_err(format!("{what}: no '{key}' key")))
}

/// An error unless `got == expected`; `unit` says what `expected` counts.
pub(crate) fn check_rows(what: &str, got: usize, expected: usize, unit: &str) -> PyResult<()> {
    if got == expected {
        Ok(())
    } else {
        Err(DefenderError::new_err(format!("{what}: expected {expected} rows ({unit}), got {got}")))
    }
}

/// The arrays of one or more episodes (or of a trajectory): observations, actions and, when
/// given, rewards, read as float32 with every value finite.
pub(crate) struct Transitions {
    pub(crate) obs: Vec<f32>,
    pub(crate) obs_rows: usize,
    pub(crate) obs_dim: usize,
    pub(crate) act: Vec<f32>,
    pub(crate) act_rows: usize,
    pub(crate) act_dim: usize,
    pub(crate) rew: Vec<f32>,
}

/// Reads `obs` [rows, obs_dim], `act` [rows, act_dim] and `rew` [rows] (when given); `prefix`
/// starts every error message (e.g. `"episode 3 "`), `dims` are checked when given.
pub(crate) fn read_transitions(
    obs: &Bound<'_, PyAny>,
    act: &Bound<'_, PyAny>,
    rew: Option<&Bound<'_, PyAny>>,
    prefix: &str,
    dims: Option<(usize, usize)>,
) -> PyResult<Transitions> {
    let (obs, obs_rows, obs_dim) = read_mat_f32(obs, &format!("{prefix}obs"), dims.map(|d| d.0), false)?;
    let (act, act_rows, act_dim) = read_mat_f32(act, &format!("{prefix}act"), dims.map(|d| d.1), false)?;
    let rew = match rew {
        Some(rew) => read_1d(rew, &format!("{prefix}rew"), "float32")?,
        None => Vec::new(),
    };
    Ok(Transitions { obs, obs_rows, obs_dim, act, act_rows, act_dim, rew })
}

/// A sequence of at least one row (a trajectory or a demonstration for DTW): float32, row-major,
/// `dim` columns when given; a 1-D array is one column when `dim` is None or 1.
pub(crate) fn read_sequence(
    x: &Bound<'_, PyAny>,
    what: &str,
    dim: Option<usize>,
) -> PyResult<(Vec<f32>, usize)> {
    let (v, rows, d) = read_mat_f32(x, what, dim, dim.is_none_or(|d| d == 1))?;
    if rows == 0 {
        return Err(DefenderError::new_err(format!("{what}: an empty sequence (it needs at least one row)")));
    }
    Ok((v, d))
}

/// A whole-number argument in `[min, max]`, read as Python's `operator.index` reads one (ints and
/// numpy integers; not floats, not strings), where `bool` is refused: `num_demos=True` is a
/// mistake, not 1. Every error names the argument `what` and the range.
pub(crate) fn whole_arg(obj: &Bound<'_, PyAny>, what: &str, min: u64, max: u64) -> PyResult<u64> {
    use pyo3::exceptions::PyTypeError;
    let range = || format!("a whole number from {min} to {max}");
    let type_name = || obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into());
    if obj.is_instance_of::<pyo3::types::PyBool>() || type_name() == "bool" {
        return Err(PyTypeError::new_err(format!("{what}: expected {}, got {obj} (a bool)", range())));
    }
    let index = obj.py().import("operator")?.call_method1("index", (obj,)).map_err(|_| {
        PyTypeError::new_err(format!("{what}: expected {}, got {obj} ({})", range(), type_name()))
    })?;
    match index.extract::<i128>() {
        Ok(v) if v >= i128::from(min) && v <= i128::from(max) => Ok(v as u64),
        _ => Err(DefenderError::new_err(format!("{what}: expected {}, got {index}", range()))),
    }
}

/// An optional count (`None` stays `None`), as [`whole_arg`] from `min`.
pub(crate) fn opt_count(obj: Option<&Bound<'_, PyAny>>, what: &str, min: u64) -> PyResult<Option<usize>> {
    obj.filter(|o| !o.is_none())
        .map(|o| whole_arg(o, what, min, usize::MAX as u64).map(|v| v as usize))
        .transpose()
}
