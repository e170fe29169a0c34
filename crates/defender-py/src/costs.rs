//! DTW, the windowed and aggregated costs of SPEC sections 2-4, and the offline ablation of SPEC
//! section 7, on numpy arrays. All release the GIL while Rust works.

use defender::{CostOptions, Demonstrations, Filter, Method, Strategy, Window};
use defender_dtw::Dtw;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::checks::{
    check_rows, parse_mode, parse_name, parse_strategies, read_sequence, read_transitions, strategy_row,
};
use crate::episodes::episode_set_arg;
use crate::select::on_local_pool;
use crate::{DefenderError, defender_err, guard};

fn dtw_err(e: defender_dtw::DtwError) -> PyErr {
    DefenderError::new_err(e.to_string())
}

/// Two sequences with the same number of columns (1-D arrays are univariate sequences).
fn pair(x: &Bound<'_, PyAny>, y: &Bound<'_, PyAny>) -> PyResult<(Vec<f32>, Vec<f32>, usize)> {
    let (x, dim) = read_sequence(x, "x", None)?;
    let (y, ydim) = read_sequence(y, "y", None)?;
    if dim != ydim {
        return Err(DefenderError::new_err(format!(
            "x and y must have the same number of columns (the element dimension): x has {dim}, y has {ydim}"
        )));
    }
    Ok((x, y, dim))
}

/// `dtw(x, y)`: the DTW cost of SPEC section 2 (Euclidean local cost, no band, f32 as the filter
/// computes it) between `x` [n, d] and `y` [m, d] (1-D arrays: d = 1).
#[pyfunction]
pub(crate) fn dtw(py: Python<'_>, x: &Bound<'_, PyAny>, y: &Bound<'_, PyAny>) -> PyResult<f64> {
    let (x, y, dim) = pair(x, y)?;
    guard("dtw", || {
        py.detach(|| defender_dtw::dtw(&x, &y, dim, &Dtw::euclidean())).map(f64::from).map_err(dtw_err)
    })
}

/// `window_cost(x, y, window)`: DTW of the parts of trajectory `x` and demonstration `y` that
/// `window` (`Both`, `Equal`, `TrajW5`, `DemoW5`, `BothW5`, `TrajW10`, `DemoW10`, `BothW10`) keeps.
#[pyfunction]
#[pyo3(signature = (x, y, window = "Both"))]
pub(crate) fn window_cost(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    y: &Bound<'_, PyAny>,
    window: &str,
) -> PyResult<f64> {
    let window: Window = parse_name(window, "window")?;
    let (x, y, dim) = pair(x, y)?;
    guard("window_cost", || {
        py.detach(|| {
            let (xr, yr) = window.ranges(x.len() / dim, y.len() / dim);
            defender_dtw::dtw(
                &x[xr.start * dim..xr.end * dim],
                &y[yr.start * dim..yr.end * dim],
                dim,
                &Dtw::euclidean(),
            )
        })
        .map(f64::from)
        .map_err(dtw_err)
    })
}

/// `group_cost(x, group, method)`: `Safe(tau)` / `Unsafe(tau)` of SPEC section 3: the method's
/// window of `x` against each sequence of `group` (a list of arrays), aggregated (`Min`, `Max`,
/// `Mean`). Returns `(value, per-demonstration costs)`.
#[pyfunction]
#[pyo3(signature = (x, group, method = "MeanDemoW5"))]
pub(crate) fn group_cost(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    group: &Bound<'_, PyList>,
    method: &str,
) -> PyResult<(f64, Vec<f64>)> {
    let method: Method = parse_name(method, "method")?;
    let (xv, dim) = read_sequence(x, "x", None)?;
    let seqs = group
        .iter()
        .enumerate()
        .map(|(i, y)| read_sequence(&y, &format!("group[{i}]"), Some(dim)))
        .collect::<PyResult<Vec<_>>>()?;
    if seqs.is_empty() {
        return Err(DefenderError::new_err("group_cost: group must be non-empty"));
    }
    guard("group_cost", || {
        py.detach(|| -> Result<(f64, Vec<f64>), defender_dtw::DtwError> {
            let n = xv.len() / dim;
            let mut costs = Vec::with_capacity(seqs.len());
            for (y, _) in &seqs {
                let (xr, yr) = method.window.ranges(n, y.len() / dim);
                costs.push(defender_dtw::dtw(
                    &xv[xr.start * dim..xr.end * dim],
                    &y[yr.start * dim..yr.end * dim],
                    dim,
                    &Dtw::euclidean(),
                )?);
            }
            Ok((method.aggregation.apply(&costs), costs.iter().map(|&c| f64::from(c)).collect()))
        })
        .map_err(dtw_err)
    })
}

/// `trajectory_costs(demos, obs, act, strategy, mode, num_demos)`: the online filter of SPEC
/// section 4 run over a whole trajectory (`obs` [T, obs_dim] the observations s_0..s_{T-1} the
/// actions were taken in, `act` [T, act_dim]), without stopping at the first filtered step.
/// Returns a dict of arrays `safe_cost`, `unsafe_cost`, `filtered` (length T).
#[pyfunction]
#[pyo3(signature = (demos, obs, act, strategy = "MeanDemoW5/MeanDemoW10", mode = "state", num_demos = None))]
pub(crate) fn trajectory_costs<'py>(
    py: Python<'py>,
    demos: &Bound<'py, PyAny>,
    obs: &Bound<'py, PyAny>,
    act: &Bound<'py, PyAny>,
    strategy: &str,
    mode: &str,
    num_demos: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let num_demos = crate::checks::opt_count(num_demos, "trajectory_costs(num_demos=...)", 1)?;
    let strategy: Strategy = parse_name(strategy, "strategy")?;
    let mode = parse_mode(mode)?;
    let mut set = episode_set_arg(demos, "demos")?;
    if let Some(n) = num_demos {
        set = set.select_demos(n).map_err(defender_err)?;
    }
    let (od, ad) = (set.obs_dim(), set.act_dim());
    let t = read_transitions(obs, act, None, "", Some((od, ad)))?;
    check_rows("act", t.act_rows, t.obs_rows, "one per row of obs: an action per step")?;
    let (o, a, rows) = (t.obs, t.act, t.obs_rows);
    let out = guard("trajectory_costs", || {
        py.detach(|| -> defender::Result<Vec<defender::Decision>> {
            let prepared = Demonstrations::new(&set, mode, CostOptions::default())?;
            let mut filter = Filter::new(&prepared, strategy)?;
            (0..rows).map(|t| filter.push_f32(&o[t * od..(t + 1) * od], &a[t * ad..(t + 1) * ad])).collect()
        })
        .map_err(defender_err)
    })?;
    let d = PyDict::new(py);
    d.set_item("safe_cost", numpy::PyArray1::from_iter(py, out.iter().map(|d| d.safe_cost)))?;
    d.set_item("unsafe_cost", numpy::PyArray1::from_iter(py, out.iter().map(|d| d.unsafe_cost)))?;
    d.set_item("filtered", numpy::PyArray1::from_iter(py, out.iter().map(|d| d.filtered)))?;
    Ok(d)
}

/// `ablate(demos, episodes, mode, strategies, as_numpy, threads)`: the offline ablation of SPEC
/// section 7 (all 576 strategies, or the given list), ranked. Returns a list of dicts (rank,
/// strategy, safe, unsafe, mode, mean_ratio, safe_rate, score) or, with `as_numpy`, a dict of
/// arrays. `threads`: how many cores replay the episodes (`None`: all).
#[pyfunction]
#[pyo3(signature = (demos, episodes, mode = "state", strategies = None, as_numpy = false, threads = None))]
pub(crate) fn ablate<'py>(
    py: Python<'py>,
    demos: &Bound<'py, PyAny>,
    episodes: &Bound<'py, PyAny>,
    mode: &str,
    strategies: Option<Vec<String>>,
    as_numpy: bool,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let threads = crate::checks::opt_count(threads, "ablate(threads=...)", 1)?;
    let mode = parse_mode(mode)?;
    let demos = episode_set_arg(demos, "demos")?;
    let episodes = episode_set_arg(episodes, "episodes")?;
    let list = parse_strategies(strategies)?;
    let rows = guard("ablate", || {
        crate::interrupt::interruptible(py, move |progress| {
            on_local_pool(threads, || {
                defender::ablate(&demos, &episodes, list.as_deref(), mode, CostOptions::default(), progress)
            })
        })??
        .map_err(defender_err)
    })?;
    if as_numpy {
        let d = PyDict::new(py);
        d.set_item("rank", numpy::PyArray1::from_iter(py, rows.iter().map(|r| r.rank as i64)))?;
        let names: Vec<String> = rows.iter().map(|r| r.strategy.to_string()).collect();
        d.set_item("strategy", py.import("numpy")?.call_method1("array", (names,))?)?;
        d.set_item("mean_ratio", numpy::PyArray1::from_iter(py, rows.iter().map(|r| r.mean_ratio)))?;
        d.set_item("safe_rate", numpy::PyArray1::from_iter(py, rows.iter().map(|r| r.safe_rate)))?;
        d.set_item("score", numpy::PyArray1::from_iter(py, rows.iter().map(|r| r.score)))?;
        return Ok(d.into_any());
    }
    let out = PyList::empty(py);
    for r in &rows {
        let d = strategy_row(py, r.rank, &r.strategy, r.mode)?;
        d.set_item("mean_ratio", r.mean_ratio)?;
        d.set_item("safe_rate", r.safe_rate)?;
        d.set_item("score", r.score)?;
        out.append(d)?;
    }
    Ok(out.into_any())
}

/// All 576 strategy names in the fixed order of SPEC section 3.
#[pyfunction]
pub(crate) fn strategies() -> Vec<String> {
    Strategy::all().map(|s| s.to_string()).collect()
}
