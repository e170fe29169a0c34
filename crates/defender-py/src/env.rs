//! The Gymnasium wrapper's core: a [`DefenderEnv`] over [`PyEnv`], a `defender_rl::Env` whose
//! `reset` and `step` call the wrapped Python environment. So every decision, cost, `R_task`,
//! prediction, outcome and counter comes from `DefenderEnv`, the code `defender train` runs; the
//! Python `DefenderWrapper` only forwards to it.

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};

use defender::selection::StrategyChoice;
use defender::{CostOptions, DefenderConfig, DefenderEnv, DynamicsConfig, FilterOptions};
use defender_rl::{BoxSpace, Env, EnvError, Outcome, Step, StepInfo};
use numpy::PyArray1;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyTuple};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::arrays::read_vec_f64;
use crate::checks::{parse_cost, parse_mode, parse_name};
use crate::episodes::episode_set_arg;
use crate::select::{AutoChoice, choose_auto};
use crate::step_cost::CostSource;
use crate::turn::{Turn, Turns};
use crate::{DefenderError, defender_err, env_err, guard};

/// The wrapped Python environment as a `defender_rl::Env`. What `DefenderEnv` cannot carry (the
/// user's action object, `reset`'s options, the environment's own observation object and `info`,
/// an exception it raised) passes through the slots below.
struct PyEnv {
    env: Py<PyAny>,
    id: String,
    observation_space: BoxSpace,
    action_space: BoxSpace,
    /// The action object to pass to `env.step` (so the environment sees the caller's own array).
    action: Option<Py<PyAny>>,
    /// `options` for the next `env.reset`.
    options: Option<Py<PyAny>>,
    /// What the environment returned last: its observation object and its `info`.
    out_obs: Option<Py<PyAny>>,
    out_info: Option<Py<PyAny>>,
    /// An exception raised by the environment (or by reading what it returned), re-raised as is.
    error: Option<PyErr>,
    /// Refuse a NaN or infinity in a reward or observation of the environment (`check_finite`).
    check_finite: bool,
    /// Steps of the wrapped environment since its last reset (named in errors).
    episode_step: u64,
    /// Where a step's cost comes from (`cost_key`).
    cost: CostSource,
}

const RAISED: &str = "the wrapped Python environment raised";

impl PyEnv {
    fn fail(&mut self, e: PyErr) -> EnvError {
        self.error = Some(e);
        EnvError::Simulator(RAISED.into())
    }

    fn read_obs(&self, obs: &Bound<'_, PyAny>, method: Method) -> PyResult<Vec<f64>> {
        let mut v = Vec::with_capacity(self.observation_space.dim());
        let what = match method {
            Method::Reset => {
                "the observation returned by the wrapped environment's reset() (its observation_space)"
            }
            Method::Step => {
                "the observation returned by the wrapped environment's step() (its observation_space)"
            }
        };
        read_vec_f64(obs, what, self.observation_space.dim(), &mut v)?;
        // DefenderEnv would skip a non-finite observation (as an unstable simulator step) and the
        // agent would get it unexplained: a Python environment returning one has a bug to fix.
        if self.check_finite
            && let Some(i) = v.iter().position(|x| !x.is_finite())
        {
            return Err(DefenderError::new_err(format!(
                "the wrapped environment's {}() returned an observation whose element {i} is {} {}; \
                 fix the environment, or pass check_finite=False to let it through",
                method.name(),
                v[i],
                self.at_step(method)
            )));
        }
        Ok(v)
    }

    /// "at step N of the episode" (or "after reset()") for error messages.
    fn at_step(&self, method: Method) -> String {
        match method {
            Method::Reset => "after reset()".into(),
            Method::Step => format!("at step {} of the episode", self.episode_step),
        }
    }
}

/// Which method of the wrapped environment returned an observation (for error messages, built
/// only when there is an error: the step path formats nothing).
#[derive(Clone, Copy)]
enum Method {
    Reset,
    Step,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Reset => "reset",
            Method::Step => "step",
        }
    }
}

impl Env for PyEnv {
    fn id(&self) -> &str {
        &self.id
    }

    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        let result = Python::attach(|py| -> PyResult<Vec<f64>> {
            let kwargs = PyDict::new(py);
            kwargs.set_item(intern!(py, "seed"), seed)?;
            kwargs.set_item(intern!(py, "options"), self.options.take())?;
            let out = self.env.bind(py).call_method(intern!(py, "reset"), (), Some(&kwargs))?;
            let (obs, info): (Bound<'_, PyAny>, Bound<'_, PyAny>) = out.extract().map_err(|_| {
                PyTypeError::new_err("the wrapped environment's reset() must return a tuple (obs, info)")
            })?;
            self.episode_step = 0;
            let v = self.read_obs(&obs, Method::Reset)?;
            self.out_obs = Some(obs.unbind());
            self.out_info = Some(info.unbind());
            Ok(v)
        });
        result.map_err(|e| self.fail(e))
    }

    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let result = Python::attach(|py| -> PyResult<Step> {
            let act = match self.action.take() {
                Some(a) => a.into_bound(py),
                None => PyArray1::from_slice(py, action).into_any(),
            };
            let out = self.env.bind(py).call_method1(intern!(py, "step"), (act,))?;
            let tuple = out.cast::<PyTuple>().ok().filter(|t| t.len() == 5).ok_or_else(|| {
                PyTypeError::new_err(
                    "the wrapped environment's step() must return a tuple (obs, reward, terminated, truncated, info)",
                )
            })?;
            let obs = tuple.get_item(0)?;
            let reward: f64 = tuple.get_item(1)?.extract().map_err(|_| {
                PyTypeError::new_err(
                    "the wrapped environment's step() returned a reward that is not a number",
                )
            })?;
            self.episode_step += 1;
            if self.check_finite && !reward.is_finite() {
                return Err(DefenderError::new_err(format!(
                    "the wrapped environment's step() returned a reward of {reward} {}; fix the \
                     environment, or pass check_finite=False to let it through",
                    self.at_step(Method::Step)
                )));
            }
            let terminated = tuple.get_item(2)?.is_truthy()?;
            let truncated = tuple.get_item(3)?.is_truthy()?;
            let v = self.read_obs(&obs, Method::Step)?;
            let info = tuple.get_item(4)?;
            let cost = self.cost.of_step(&info, terminated, &|| self.at_step(Method::Step))?;
            self.out_obs = Some(obs.unbind());
            self.out_info = Some(info.unbind());
            Ok(Step { obs: v, reward, cost, terminated, truncated, info: StepInfo::default() })
        });
        result.map_err(|e| self.fail(e))
    }
}

/// A Box space's bounds read from Python arrays.
fn box_space(
    py: Python<'_>,
    low: &Bound<'_, PyAny>,
    high: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<BoxSpace> {
    let np = py.import("numpy")?;
    let flat = |a: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
        np.call_method1("asarray", (a, np.getattr("float64")?))?
            .call_method0("ravel")?
            .call_method0("tolist")?
            .extract()
    };
    BoxSpace::new(flat(low)?, flat(high)?).map_err(|e| DefenderError::new_err(format!("{what}: {e}")))
}

fn outcome_name(o: Outcome) -> &'static str {
    o.as_str()
}

struct State {
    env: DefenderEnv<PyEnv>,
    act: Vec<f64>,
    closed: bool,
}

/// The Rust core of `defender_rl.DefenderWrapper` (use the wrapper; this class has no
/// Gymnasium interface of its own).
///
/// One call at a time: a second thread waits for its turn with the GIL released, a re-entrant
/// call raises at once ([`Turns`]).
#[pyclass(module = "defender_rl._core")]
pub struct Core {
    turns: Turns,
    /// Taken only inside a turn, so never contended: it makes `Core` `Sync` for PyO3.
    state: Mutex<State>,
    /// dtype of the observation space (a prediction is returned in it).
    obs_dtype: Py<PyAny>,
    obs_dim: usize,
    /// How `strategy="auto"` chose the strategy; None for a given strategy.
    auto: Option<AutoChoice>,
}

/// A call's exclusive access to the state. The fields drop in order: the state's lock, then the
/// turn (which lets the next thread in).
struct Entered<'a> {
    state: MutexGuard<'a, State>,
    _turn: Turn<'a>,
}

impl std::ops::Deref for Entered<'_> {
    type Target = State;
    fn deref(&self) -> &State {
        &self.state
    }
}

impl std::ops::DerefMut for Entered<'_> {
    fn deref_mut(&mut self) -> &mut State {
        &mut self.state
    }
}

impl Core {
    /// The turn of `method` and the state, refused once the wrapper is closed.
    fn lock(&self, py: Python<'_>, method: &'static str) -> PyResult<Entered<'_>> {
        let entered = self.enter(py, method)?;
        if entered.closed {
            return Err(PyRuntimeError::new_err(format!(
                "DefenderWrapper.{method}(): the wrapper is closed (close() was called); make a new one \
                 to keep using DEFENDER"
            )));
        }
        Ok(entered)
    }

    fn enter(&self, py: Python<'_>, method: &'static str) -> PyResult<Entered<'_>> {
        let turn = self.turns.take(py, method)?;
        let state = self.state.lock().map_err(|_| {
            PyRuntimeError::new_err("DefenderWrapper: an earlier call failed inside Rust; make a new wrapper")
        })?;
        Ok(Entered { state, _turn: turn })
    }
}

fn take_error(state: &mut State, e: EnvError) -> PyErr {
    match state.env.inner_mut().error.take() {
        Some(py_err) => py_err,
        None => env_err(e),
    }
}

#[pymethods]
impl Core {
    /// `env`: the Python environment; `obs_low`/`obs_high`/`act_low`/`act_high`: its Box bounds;
    /// `dynamics`: a JSON object of `DynamicsConfig` fields; `filter`: one of `FilterOptions`;
    /// `cost_key`: the `info` key of a step's cost (None: the crash rule), `cost_key_required`:
    /// whether a step without it raises (the user named the key).
    #[new]
    #[pyo3(signature = (env, env_id, obs_low, obs_high, obs_dtype, act_low, act_high, demos, strategy, mode, num_demos, r_task, dynamics_json, seed, scaling, check_finite = true, filter_json = None, cost_key = Some("cost".to_string()), cost_key_required = false, episode_cost_limit = None))]
    #[allow(clippy::too_many_arguments)] // one Python constructor, all keyword-checked in Python
    fn new(
        py: Python<'_>,
        env: Py<PyAny>,
        env_id: Option<String>,
        obs_low: &Bound<'_, PyAny>,
        obs_high: &Bound<'_, PyAny>,
        obs_dtype: Py<PyAny>,
        act_low: &Bound<'_, PyAny>,
        act_high: &Bound<'_, PyAny>,
        demos: &Bound<'_, PyAny>,
        strategy: &str,
        mode: &str,
        num_demos: Option<usize>,
        r_task: Option<f64>,
        dynamics_json: Option<String>,
        seed: Option<u64>,
        scaling: Option<&str>,
        check_finite: bool,
        filter_json: Option<String>,
        cost_key: Option<String>,
        cost_key_required: bool,
        episode_cost_limit: Option<f64>,
    ) -> PyResult<Self> {
        guard("DefenderWrapper()", || {
            let observation_space = box_space(py, obs_low, obs_high, "observation_space")?;
            let action_space = box_space(py, act_low, act_high, "action_space")?;
            let demos = episode_set_arg(demos, "demos")?;
            let choice: StrategyChoice = parse_name(strategy, "strategy")?;
            let mode = parse_mode(mode)?;
            let given_cost = scaling.map(parse_cost).transpose()?;
            let dynamics: DynamicsConfig = match dynamics_json {
                Some(text) => serde_json::from_str(&text)
                    .map_err(|e| DefenderError::new_err(format!("dynamics: {e}")))?,
                None => DynamicsConfig::default(),
            };
            let filter: FilterOptions = match filter_json {
                Some(text) => {
                    serde_json::from_str(&text).map_err(|e| DefenderError::new_err(format!("filter: {e}")))?
                }
                None => FilterOptions::default(),
            };
            filter.validate().map_err(|e| DefenderError::new_err(format!("filter: {e}")))?;
            if let Some(r) = r_task.filter(|r| !r.is_finite()) {
                return Err(DefenderError::new_err(format!("r_task must be a finite number, got {r}")));
            }
            // Without a Gymnasium id (an environment made without gymnasium.make), the
            // demonstrations' id stands in: only dimensions are checked then.
            let id = env_id.or_else(|| demos.meta().env_id.clone()).unwrap_or_else(|| "<python env>".into());
            let obs_dim = observation_space.dim();
            let inner = PyEnv {
                env,
                id,
                observation_space,
                action_space,
                action: None,
                options: None,
                out_obs: None,
                out_info: None,
                error: None,
                check_finite,
                episode_step: 0,
                cost: CostSource::new(cost_key, cost_key_required),
            };
            // strategy="auto": chosen here, from these demonstrations, as `defender train
            // --strategy auto` chooses (docs/decisions.md).
            // Without a scaling, auto compares plain and z-scored DTW; a given strategy uses
            // plain DTW (SPEC section 2).
            let (strategy, cost, auto) = match choice {
                StrategyChoice::Fixed(s) => (s, given_cost.unwrap_or_default(), None),
                StrategyChoice::Auto => {
                    let auto = choose_auto(py, &demos, mode, num_demos, given_cost)?;
                    (
                        auto.best.strategy,
                        CostOptions { scaling: auto.best.scaling, ..given_cost.unwrap_or_default() },
                        Some(auto),
                    )
                }
            };
            let config = DefenderConfig {
                strategy,
                mode,
                num_demos,
                r_task,
                cost,
                filter,
                // docs/SPEC.md section 13: the demonstrations' own limit unless one is given
                // (then they must have been labelled by it).
                episode_cost_limit: match episode_cost_limit {
                    Some(l) => Some(l),
                    None => match defender::UnsafeRule::of_set(&demos)
                        .map_err(|e| DefenderError::new_err(format!("demos: {e}")))?
                    {
                        defender::UnsafeRule::CostAbove(l) => Some(l),
                        defender::UnsafeRule::Crash => None,
                    },
                },
                filtered_cost: defender::FilteredCost::None,
                dynamics,
            };
            let mut rng = match seed {
                Some(s) => ChaCha8Rng::seed_from_u64(s),
                None => ChaCha8Rng::from_rng(&mut rand::rng()),
            };
            let env = DefenderEnv::new(inner, &demos, config, &mut rng).map_err(|e| {
                // Errors about the file name it already (`PATH: array 'obs': ...`).
                let (source, e) = (demos.source().display().to_string(), e.to_string());
                let at = if e.contains(&source) { String::new() } else { format!(" {source}") };
                DefenderError::new_err(format!("DefenderWrapper: demonstrations{at}: {e}"))
            })?;
            // The model's GEMMs run on the calling thread unless DEFENDER_NN_THREADS asks for
            // more: rayon's global pool does not survive fork(), and vector environments fork
            // (gymnasium's AsyncVectorEnv by default) after the parent may have used it. Results
            // are bit-identical either way.
            let parallelism = if std::env::var_os("DEFENDER_NN_THREADS").is_some() {
                defender_nn::Parallelism::default()
            } else {
                defender_nn::Parallelism::Sequential
            };
            env.dynamics().map_err(defender_err)?.set_parallelism(parallelism);
            let act_dim = env.action_space().dim();
            Ok(Self {
                turns: Turns::default(),
                state: Mutex::new(State { env, act: Vec::with_capacity(act_dim), closed: false }),
                obs_dtype,
                obs_dim,
                auto,
            })
        })
    }

    /// `env.reset(seed=seed, options=options)` through `DefenderEnv::reset`: `(obs, info)`.
    #[pyo3(signature = (seed=None, options=None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<&Bound<'py, PyAny>>,
        options: Option<Py<PyAny>>,
    ) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let seed: Option<u64> = match seed.filter(|s| !s.is_none()) {
            None => None,
            Some(s) => Some(s.extract().map_err(|_| {
                PyValueError::new_err(format!(
                    "reset(seed=...): expected a non-negative integer below 2**64, got {s}"
                ))
            })?),
        };
        let mut state = self.lock(py, "reset")?;
        guard("DefenderWrapper.reset", || {
            state.env.inner_mut().options = options;
            // Without the GIL: the wrapped environment's reset takes it back (PyEnv::reset).
            let env = &mut state.env;
            match py.detach(|| env.reset(seed)) {
                Ok(_) => {
                    let inner = state.env.inner_mut();
                    let obs = inner.out_obs.take().unwrap_or_else(|| py.None());
                    let info = match inner.out_info.take() {
                        Some(i) => i,
                        None => PyDict::new(py).into_any().unbind(),
                    };
                    Ok((obs, info))
                }
                Err(e) => Err(take_error(&mut state, e)),
            }
        })
    }

    /// One step through `DefenderEnv::step`: `(obs, reward, terminated, truncated, info)`.
    fn step<'py>(&self, py: Python<'py>, action: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyTuple>> {
        let mut guard_state = self.lock(py, "step")?;
        guard("DefenderWrapper.step", || {
            let state = &mut *guard_state;
            let act_dim = state.env.action_space().dim();
            read_vec_f64(action, "DefenderWrapper.step(action) (the action_space)", act_dim, &mut state.act)?;
            if state.env.inner().check_finite
                && let Some(i) = state.act.iter().position(|x| !x.is_finite())
            {
                return Err(DefenderError::new_err(format!(
                    "DefenderWrapper.step(action): element {i} of the action is {} at step {} of the \
                     episode; fix the agent, or pass check_finite=False to let it through",
                    state.act[i],
                    state.env.inner().episode_step + 1
                )));
            }
            state.env.inner_mut().action = Some(action.clone().unbind());
            // Without the GIL: the filter and the dynamics model are Rust; the wrapped
            // environment's step takes the GIL back (PyEnv::step).
            let (env, act) = (&mut state.env, &state.act);
            let result = py.detach(|| env.step(act));
            state.env.inner_mut().action = None;
            let step = match result {
                Ok(step) => step,
                Err(e) => return Err(take_error(state, e)),
            };
            let decision = state.env.last_decision();
            let filtered = step.info.filtered;
            let done = step.done();
            let inner = state.env.inner_mut();
            let (obs, info) = if filtered {
                let pred = PyArray1::from_vec(py, step.obs).into_any();
                let pred = pred.call_method1(intern!(py, "astype"), (self.obs_dtype.bind(py),))?;
                (pred, PyDict::new(py))
            } else {
                let obs = inner
                    .out_obs
                    .take()
                    .map(|o| o.into_bound(py))
                    .unwrap_or_else(|| py.None().into_bound(py));
                // The environment's own info dict gets the DEFENDER keys in place, as Gymnasium's
                // wrappers add theirs (RecordEpisodeStatistics' "episode"): no copy per step.
                let info = match inner.out_info.take().map(|i| i.into_bound(py)) {
                    Some(i) => match i.cast_into::<PyDict>() {
                        Ok(d) => d,
                        Err(_) => PyDict::new(py),
                    },
                    None => PyDict::new(py),
                };
                (obs, info)
            };
            // The cost used (0 on a filtered step: the action never reached the environment).
            info.set_item(intern!(py, "cost"), step.cost)?;
            info.set_item(intern!(py, "defender_filtered"), filtered)?;
            if let Some(d) = decision {
                info.set_item(intern!(py, "defender_safe_cost"), d.safe_cost)?;
                info.set_item(intern!(py, "defender_unsafe_cost"), d.unsafe_cost)?;
            }
            if done && let Some(o) = state.env.last_outcome() {
                info.set_item(intern!(py, "defender_outcome"), outcome_name(o))?;
            }
            PyTuple::new(
                py,
                [
                    obs,
                    PyFloat::new(py, step.reward).into_any(),
                    PyBool::new(py, step.terminated).to_owned().into_any(),
                    PyBool::new(py, step.truncated).to_owned().into_any(),
                    info.into_any(),
                ],
            )
        })
    }

    /// Counters since construction (as `DefenderStats`).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.lock(py, "defender_stats")?.env.stats();
        let d = PyDict::new(py);
        for (k, v) in [
            ("steps", s.steps),
            ("filtered_steps", s.filtered_steps),
            ("real_steps", s.real_steps),
            ("episodes", s.episodes),
            ("filtered_episodes", s.filtered_episodes),
            ("crashed_episodes", s.crashed_episodes),
            ("truncated_episodes", s.truncated_episodes),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// The filter's precision options as they stand (they move between episodes): `margin`,
    /// `own_safe`, `own_unsafe`.
    fn filter_state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let state = self.lock(py, "filter_state")?;
        let filter = state.env.adaptive_filter();
        let (own_safe, own_unsafe) = filter.own_counts();
        let d = PyDict::new(py);
        d.set_item("margin", filter.margin())?;
        d.set_item("own_safe", own_safe)?;
        d.set_item("own_unsafe", own_unsafe)?;
        Ok(d)
    }

    /// The last step's decision: `(filtered, safe_cost, unsafe_cost)`, or None.
    fn last_decision(&self, py: Python<'_>) -> PyResult<Option<(bool, f64, f64)>> {
        Ok(self
            .lock(py, "last_decision")?
            .env
            .last_decision()
            .map(|d| (d.filtered, d.safe_cost, d.unsafe_cost)))
    }

    /// How the last finished episode ended: `crashed`, `filtered`, `truncated`, or None.
    fn last_outcome(&self, py: Python<'_>) -> PyResult<Option<&'static str>> {
        Ok(self.lock(py, "last_outcome")?.env.last_outcome().map(outcome_name))
    }

    /// The reward of a filtered step, as used.
    fn r_task(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py, "r_task")?.env.r_task())
    }

    /// The strategy and mode in use, as strings.
    fn config(&self, py: Python<'_>) -> PyResult<(String, String, Option<usize>)> {
        let s = self.lock(py, "config")?;
        let c = s.env.config();
        Ok((c.strategy.to_string(), c.mode.to_string(), c.num_demos))
    }

    /// With `strategy="auto"`: the chosen strategy and its scores (a dict); None otherwise.
    fn selection<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.auto.as_ref().map(|a| a.to_dict(py)).transpose()
    }

    /// The dynamics model's counters and prediction error (a dict).
    fn dynamics_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let state = self.lock(py, "dynamics_info")?;
        let model = state.env.dynamics().map_err(defender_err)?;
        let err = model.prediction_error();
        let d = PyDict::new(py);
        d.set_item("real_steps", model.real_steps())?;
        d.set_item("gradient_steps", model.gradient_steps())?;
        d.set_item("buffer_len", model.buffer_len())?;
        d.set_item("last_loss", model.last_loss())?;
        d.set_item("prediction_error_count", err.count)?;
        d.set_item("prediction_error_last", err.last)?;
        d.set_item("prediction_error_ema", err.ema)?;
        d.set_item("prediction_error_mean", err.mean)?;
        Ok(d)
    }

    /// The dynamics model's prediction of the next observation (does not train it).
    fn predict<'py>(
        &self,
        py: Python<'py>,
        obs: &Bound<'py, PyAny>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mut state = self.lock(py, "predict")?;
        let act_dim = state.env.action_space().dim();
        let (mut o, mut a) = (Vec::new(), Vec::new());
        read_vec_f64(obs, "predict(obs)", self.obs_dim, &mut o)?;
        read_vec_f64(action, "predict(action)", act_dim, &mut a)?;
        let env = &mut state.env;
        let out = guard("DefenderWrapper.predict", || {
            py.detach(move || {
                let mut model = env.dynamics()?;
                model.predict(&o, &a)
            })
            .map_err(defender_err)
        })?;
        Ok(PyArray1::from_vec(py, out).into_any())
    }

    /// Writes the dynamics model and the counters into the folder `path` (made if missing; it
    /// must be empty). Call between episodes, e.g. beside an agent's checkpoint.
    fn save_state(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let mut state = self.lock(py, "save_state")?;
        guard("DefenderWrapper.save_state", || {
            if path.exists() && std::fs::read_dir(&path).map(|mut d| d.next().is_some()).unwrap_or(true) {
                return Err(DefenderError::new_err(format!(
                    "save_state: {} exists and is not an empty folder (choose a new one)",
                    path.display()
                )));
            }
            std::fs::create_dir_all(&path)
                .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", path.display())))?;
            let env = &mut state.env;
            let path = &path;
            py.detach(move || env.save_state(path)).map_err(env_err)
        })
    }

    /// Restores what `save_state` wrote; the next call must be `reset()`.
    fn load_state(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let mut state = self.lock(py, "load_state")?;
        let env = &mut state.env;
        guard("DefenderWrapper.load_state", || py.detach(|| env.load_state(&path)).map_err(env_err))
    }

    /// Refuses further calls (after the call in progress on another thread, if any).
    ///
    /// # Errors
    /// A re-entrant call (from inside the wrapped environment's `step`), or Ctrl-C while waiting.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        match self.enter(py, "close") {
            Ok(mut s) => s.closed = true,
            // A poisoned state (an earlier panic) is closed all the same.
            Err(e) if e.is_instance_of::<PyRuntimeError>(py) && self.state.is_poisoned() => {}
            Err(e) => return Err(e),
        }
        Ok(())
    }
}
