//! Choosing the strategy automatically: `defender_rl.select(...)` and the wrapper's
//! `strategy="auto"`, both by [`defender::selection::select`], the code of `defender select` and
//! `defender train --strategy auto` (docs/decisions.md, "Choosing the strategy automatically").

use std::time::Instant;

use defender::selection::{AUTO_COSTS, Selection, SelectionConfig, StrategyScore, select};
use defender::{CostOptions, EpisodeSet, Mode};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::checks::{opt_count, parse_cost, parse_mode, parse_strategies, strategy_row, whole_arg};
use crate::episodes::episode_set_arg;
use crate::{DefenderError, defender_err, guard};

/// Runs `f` on a rayon pool of its own, dropped when `f` returns, instead of rayon's global pool:
/// the global pool does not survive `fork()`, and vector environments fork (docs/decisions-python.md,
/// "The Python front"). `threads`: the pool's size (a Ray task given one CPU asks for 1);
/// `None`: every core.
pub(crate) fn on_local_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    if threads == Some(0) {
        return Err(DefenderError::new_err("threads: 0; give at least 1 (or None for every core)"));
    }
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("defender-select-{i}"))
        .build()
        .map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!("cannot start worker threads: {e}"))
        })?;
    Ok(pool.install(f))
}

/// What `strategy="auto"` chose, and how: the fields `defender train --strategy auto` records
/// in `config.toml` (`[defender.selection]`) and `summary.json` (`selection`).
pub(crate) struct AutoChoice {
    pub(crate) best: StrategyScore,
    candidates: usize,
    equal: bool,
    min_lead: usize,
    max_false_alarm: f64,
    demos: (usize, usize),
    seconds: f64,
    /// The scalings compared (empty when the wrapper was given one).
    scalings: Vec<String>,
}

impl AutoChoice {
    /// The record as a dict (`DefenderWrapper.strategy_selection`).
    pub(crate) fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let b = &self.best;
        let d = PyDict::new(py);
        d.set_item("strategy", b.strategy.to_string())?;
        d.set_item("scaling", b.scaling.to_string())?;
        d.set_item("chosen_by", "auto")?;
        d.set_item("candidates", self.candidates)?;
        d.set_item("equal", self.equal)?;
        d.set_item("min_lead", self.min_lead)?;
        d.set_item("max_false_alarm", self.max_false_alarm)?;
        d.set_item("safe_demos", self.demos.0)?;
        d.set_item("unsafe_demos", self.demos.1)?;
        d.set_item("false_alarm_rate", b.false_alarm_rate)?;
        d.set_item("crash_prevention_rate", b.crash_prevention_rate)?;
        d.set_item("safe_allowed", b.safe_allowed)?;
        d.set_item("unsafe_allowed", b.unsafe_allowed)?;
        d.set_item("mean_lead", b.mean_lead)?;
        d.set_item("score", b.score)?;
        d.set_item("seconds", self.seconds)?;
        d.set_item("scalings", self.scalings.clone())?;
        Ok(d)
    }
}

/// `strategy="auto"`: the selection `defender train --strategy auto` runs (state or
/// state-action mode and `num_demos` as the run's, without the `Equal` window, under `cost` if
/// given, else comparing plain and z-scored DTW, the default lead time and false-alarm budget),
/// without the GIL.
///
/// # Errors
/// As [`select`]; and when no strategy is eligible (the same refusal as `defender train`).
pub(crate) fn choose_auto(
    py: Python<'_>,
    demos: &EpisodeSet,
    mode: Mode,
    num_demos: Option<usize>,
    cost: Option<CostOptions>,
) -> PyResult<AutoChoice> {
    let config = SelectionConfig::for_run(mode, num_demos, cost);
    let start = Instant::now();
    // The selection's thread owns what it reads (it outlives this call after a Ctrl-C).
    let (owned, run_config) = (demos.clone(), config.clone());
    let selection = crate::interrupt::interruptible(py, move |progress| {
        on_local_pool(None, || select(&owned, None, &run_config, progress))
    })??
    .map_err(|e| DefenderError::new_err(format!("strategy=\"auto\": {e}")))?;
    let Some(best) = selection.best().cloned() else {
        return Err(DefenderError::new_err(format!(
            "strategy=\"auto\": every strategy filters more than {}% of the held-out safe \
             demonstrations of {} (false alarms that would stop the agent from learning); rank them \
             with defender_rl.select(...) and give strategy=\"SAFE/UNSAFE\"",
            100.0 * config.max_false_alarm,
            demos.source().display()
        )));
    };
    Ok(AutoChoice {
        best,
        candidates: selection.rows.len() / config.costs.len(),
        equal: config.equal,
        min_lead: config.min_lead,
        max_false_alarm: config.max_false_alarm,
        demos: selection.demos,
        seconds: start.elapsed().as_secs_f64(),
        scalings: if config.costs.len() > 1 {
            config.costs.iter().map(|c| c.scaling.to_string()).collect()
        } else {
            Vec::new()
        },
    })
}

/// `select(demos, episodes=None, mode="state", num_demos=None, equal=True, strategies=None,
/// min_lead=1, max_false_alarm=0.1, as_numpy=False, scaling="none")`: ranks strategies for one task from its
/// demonstrations by leave-one-out, times the ablation score on recorded `episodes` when given,
/// as `defender select` does (same options, same rows as its `selection.csv`; `scaling="auto"`
/// ranks plain and z-scored DTW together, as `strategy="auto"` compares them). The first row is
/// the choice when its `eligible` is true. Returns a list of dicts, or with `as_numpy` a dict of
/// arrays.
#[pyfunction(name = "select")]
#[pyo3(signature = (demos, episodes = None, mode = "state", num_demos = None, equal = true, strategies = None, min_lead = None, max_false_alarm = 0.1, as_numpy = false, scaling = "none"))]
#[allow(clippy::too_many_arguments)] // keyword arguments of one Python function, as `defender select`'s flags
pub(crate) fn select_strategies<'py>(
    py: Python<'py>,
    demos: &Bound<'py, PyAny>,
    episodes: Option<&Bound<'py, PyAny>>,
    mode: &str,
    num_demos: Option<&Bound<'py, PyAny>>,
    equal: bool,
    strategies: Option<Vec<String>>,
    min_lead: Option<&Bound<'py, PyAny>>,
    max_false_alarm: f64,
    as_numpy: bool,
    scaling: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let num_demos = opt_count(num_demos, "select(num_demos=...)", 1)?;
    // None: the default lead of 1 step.
    let min_lead = match min_lead.filter(|m| !m.is_none()) {
        Some(m) => whole_arg(m, "select(min_lead=...)", 0, usize::MAX as u64)? as usize,
        None => 1,
    };
    if !(0.0..=1.0).contains(&max_false_alarm) {
        return Err(DefenderError::new_err(format!(
            "select(max_false_alarm=...): expected a fraction from 0 to 1, got {max_false_alarm}"
        )));
    }
    let mode = parse_mode(mode)?;
    let costs = if scaling == "auto" { AUTO_COSTS.to_vec() } else { vec![parse_cost(scaling)?] };
    let demos = episode_set_arg(demos, "demos")?;
    let episodes = episodes.filter(|e| !e.is_none()).map(|e| episode_set_arg(e, "episodes")).transpose()?;
    let strategies = parse_strategies(strategies)?;
    let config = SelectionConfig { mode, num_demos, equal, strategies, min_lead, max_false_alarm, costs };
    let selection = guard("select", || {
        crate::interrupt::interruptible(py, move |progress| {
            on_local_pool(None, || select(&demos, episodes.as_ref(), &config, progress))
        })??
        .map_err(defender_err)
    })?;
    if as_numpy { numpy_rows(py, &selection) } else { dict_rows(py, &selection) }
}

fn dict_rows<'py>(py: Python<'py>, selection: &Selection) -> PyResult<Bound<'py, PyAny>> {
    let out = PyList::empty(py);
    for r in &selection.rows {
        let d = strategy_row(py, r.rank, &r.strategy, r.mode)?;
        d.set_item("scaling", r.scaling.to_string())?;
        d.set_item("false_alarm_rate", r.false_alarm_rate)?;
        d.set_item("crash_prevention_rate", r.crash_prevention_rate)?;
        d.set_item("safe_allowed", r.safe_allowed)?;
        d.set_item("unsafe_allowed", r.unsafe_allowed)?;
        d.set_item("mean_lead", r.mean_lead)?;
        d.set_item("demo_score", r.demo_score)?;
        d.set_item("ablation_score", r.ablation_score)?;
        d.set_item("score", r.score)?;
        d.set_item("eligible", r.eligible)?;
        out.append(d)?;
    }
    Ok(out.into_any())
}

fn numpy_rows<'py>(py: Python<'py>, selection: &Selection) -> PyResult<Bound<'py, PyAny>> {
    use numpy::PyArray1;
    let rows = &selection.rows;
    let f = |get: fn(&StrategyScore) -> f64| PyArray1::from_iter(py, rows.iter().map(get));
    let d = PyDict::new(py);
    d.set_item("rank", PyArray1::from_iter(py, rows.iter().map(|r| r.rank as i64)))?;
    let names: Vec<String> = rows.iter().map(|r| r.strategy.to_string()).collect();
    d.set_item("strategy", py.import("numpy")?.call_method1("array", (names,))?)?;
    let scalings: Vec<String> = rows.iter().map(|r| r.scaling.to_string()).collect();
    d.set_item("scaling", py.import("numpy")?.call_method1("array", (scalings,))?)?;
    d.set_item("false_alarm_rate", f(|r| r.false_alarm_rate))?;
    d.set_item("crash_prevention_rate", f(|r| r.crash_prevention_rate))?;
    d.set_item("safe_allowed", f(|r| r.safe_allowed))?;
    d.set_item("unsafe_allowed", f(|r| r.unsafe_allowed))?;
    d.set_item("mean_lead", f(|r| r.mean_lead))?;
    d.set_item("demo_score", f(|r| r.demo_score))?;
    // NaN without recorded episodes (as the empty column of selection.csv).
    d.set_item("ablation_score", f(|r| r.ablation_score.unwrap_or(f64::NAN)))?;
    d.set_item("score", f(|r| r.score))?;
    d.set_item("eligible", PyArray1::from_iter(py, rows.iter().map(|r| r.eligible)))?;
    Ok(d.into_any())
}
