//! `EpisodeSet`: demonstration sets and recorded episode sets (SPEC sections 1 and 8) in numpy.

use std::path::PathBuf;

use pyo3::exceptions::{PyIndexError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};

use crate::arrays::{mat, read_1d};
use crate::checks::{Transitions, check_rows, read_transitions, required_item};
use crate::{DefenderError, defender_err, guard};

/// A set of episodes: observations (the final one of each episode included), actions, rewards,
/// and whether each episode crashed (the environment terminated it). As demonstrations, crashed
/// episodes are the unsafe group and the others the safe group.
///
/// Stored in float32 as in the `.npz` file format (SPEC section 8): `obs` [sum(N_i + 1), obs_dim],
/// `act` [sum(N_i), act_dim], `rew` [sum(N_i)], `ep_len` [E] int64, `crashed` [E] bool and
/// `meta` (JSON).
#[pyclass(module = "defender_rl._core", frozen)]
pub struct EpisodeSet {
    pub(crate) inner: defender::EpisodeSet,
}

pub(crate) fn meta_to_py<'py>(py: Python<'py>, meta: &defender::Meta) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(meta).map_err(|e| DefenderError::new_err(format!("meta: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

fn meta_from_py(meta: Option<&Bound<'_, PyAny>>) -> PyResult<defender::Meta> {
    let Some(meta) = meta.filter(|m| !m.is_none()) else {
        return Ok(defender::Meta::default());
    };
    let text: String = if let Ok(s) = meta.extract::<String>() {
        s
    } else if meta.is_instance_of::<PyDict>() {
        meta.py().import("json")?.call_method1("dumps", (meta,))?.extract()?
    } else {
        return Err(PyTypeError::new_err("meta: expected a dict (JSON-serialisable) or a JSON string"));
    };
    serde_json::from_str(&text).map_err(|e| {
        DefenderError::new_err(format!("meta: not a JSON object of the episode-set format: {e}"))
    })
}

/// The dimensions `meta` states must be the arrays' (as `EpisodeSet.load` requires of a file).
fn check_meta_dims(meta: &defender::Meta, obs_dim: usize, act_dim: usize) -> PyResult<()> {
    for (name, stated, actual) in [("obs_dim", meta.obs_dim, obs_dim), ("act_dim", meta.act_dim, act_dim)] {
        if let Some(stated) = stated
            && stated != actual
        {
            return Err(DefenderError::new_err(format!(
                "meta: {name} is {stated} but the arrays have {actual} columns"
            )));
        }
    }
    Ok(())
}

impl EpisodeSet {
    pub(crate) fn from_inner(inner: defender::EpisodeSet) -> Self {
        Self { inner }
    }
}

/// Reads `demos` given as an `EpisodeSet`, a path (str or os.PathLike) or a dict of arrays.
pub(crate) fn episode_set_arg(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<defender::EpisodeSet> {
    if let Ok(set) = obj.cast::<EpisodeSet>() {
        return Ok(set.get().inner.clone());
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let get = |k: &str| required_item(d, k, &format!("{what} (a dict of arrays)"));
        let meta = d.get_item("meta")?;
        return from_arrays_impl(
            &get("obs")?,
            &get("act")?,
            &get("rew")?,
            &get("ep_len")?,
            &get("crashed")?,
            meta.as_ref(),
        );
    }
    if let Ok(path) = obj.extract::<PathBuf>() {
        let py = obj.py();
        return py.detach(|| defender::EpisodeSet::load(&path)).map_err(defender_err);
    }
    Err(PyTypeError::new_err(format!(
        "{what}: expected an EpisodeSet, a path to an .npz file or a dict of arrays, got {}",
        obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
    )))
}

fn from_arrays_impl(
    obs: &Bound<'_, PyAny>,
    act: &Bound<'_, PyAny>,
    rew: &Bound<'_, PyAny>,
    ep_len: &Bound<'_, PyAny>,
    crashed: &Bound<'_, PyAny>,
    meta: Option<&Bound<'_, PyAny>>,
) -> PyResult<defender::EpisodeSet> {
    let Transitions { obs, obs_rows, obs_dim, act, act_rows, act_dim, rew } =
        read_transitions(obs, act, Some(rew), "", None)?;
    let ep_len: Vec<i64> = read_1d(ep_len, "ep_len", "int64")?;
    let crashed: Vec<bool> = read_1d(crashed, "crashed", "bool_")?;
    let meta = meta_from_py(meta)?;
    if ep_len.len() != crashed.len() {
        return Err(DefenderError::new_err(format!(
            "crashed: expected one flag per episode ({} episodes in ep_len), got {}",
            ep_len.len(),
            crashed.len()
        )));
    }
    if let Some(i) = ep_len.iter().position(|&n| n < 1) {
        return Err(DefenderError::new_err(format!(
            "ep_len: episode {i} has {} transitions (each needs at least 1)",
            ep_len[i]
        )));
    }
    let total: usize = ep_len.iter().map(|&n| n as usize).sum();
    let episodes = ep_len.len();
    let unit = format!("sum(ep_len) = {total} over {episodes} episodes");
    check_rows(
        "obs",
        obs_rows,
        total + episodes,
        &format!("{unit}, plus one final observation per episode"),
    )?;
    check_rows("act", act_rows, total, &unit)?;
    check_rows("rew", rew.len(), total, &unit)?;
    check_meta_dims(&meta, obs_dim, act_dim)?;
    let mut set = defender::EpisodeSet::new(obs_dim, act_dim, meta).map_err(defender_err)?;
    let (mut o, mut a) = (0usize, 0usize);
    for (&n, &c) in ep_len.iter().zip(&crashed) {
        let n = n as usize;
        set.push_episode(
            &obs[o * obs_dim..(o + n + 1) * obs_dim],
            &act[a * act_dim..(a + n) * act_dim],
            &rew[a..a + n],
            c,
        )
        .map_err(defender_err)?;
        o += n + 1;
        a += n;
    }
    Ok(set)
}

#[pymethods]
impl EpisodeSet {
    /// Builds a set from the arrays of the file format (SPEC section 8): `obs` [sum(N_i + 1),
    /// obs_dim], `act` [sum(N_i), act_dim], `rew` [sum(N_i)], `ep_len` [E], `crashed` [E], and
    /// `meta` (a dict or a JSON string; optional).
    #[classmethod]
    #[pyo3(signature = (obs, act, rew, ep_len, crashed, meta=None))]
    fn from_arrays(
        _cls: &Bound<'_, PyType>,
        obs: &Bound<'_, PyAny>,
        act: &Bound<'_, PyAny>,
        rew: &Bound<'_, PyAny>,
        ep_len: &Bound<'_, PyAny>,
        crashed: &Bound<'_, PyAny>,
        meta: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard("EpisodeSet.from_arrays", || {
            from_arrays_impl(obs, act, rew, ep_len, crashed, meta).map(Self::from_inner)
        })
    }

    /// Reads an `.npz` episode-set file (float32 or float64 arrays; validated).
    #[classmethod]
    fn load(_cls: &Bound<'_, PyType>, py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        guard("EpisodeSet.load", || {
            py.detach(|| defender::EpisodeSet::load(&path)).map(Self::from_inner).map_err(defender_err)
        })
    }

    /// Turns a Minari dataset's episodes into an episode set (see `defender_rl.from_minari`).
    #[classmethod]
    #[pyo3(signature = (dataset, *, crashed=None, env_id=None, episode_indices=None))]
    fn from_minari<'py>(
        _cls: &Bound<'py, PyType>,
        py: Python<'py>,
        dataset: &Bound<'py, PyAny>,
        crashed: Option<&Bound<'py, PyAny>>,
        env_id: Option<String>,
        episode_indices: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kwargs = PyDict::new(py);
        kwargs.set_item("crashed", crashed)?;
        kwargs.set_item("env_id", env_id)?;
        kwargs.set_item("episode_indices", episode_indices)?;
        py.import("defender_rl._minari")?.getattr("from_minari")?.call((dataset,), Some(&kwargs))
    }

    /// Writes the set as `.npz` (atomically); `numpy.load(path)` reads it.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        guard("EpisodeSet.save", || py.detach(|| self.inner.save(&path)).map_err(defender_err))
    }

    /// Builds a set from a list of episodes, each a tuple `(obs [N+1, obs_dim], act [N, act_dim],
    /// rew [N], crashed)` or a dict with those keys.
    #[classmethod]
    #[pyo3(signature = (episodes, *, env_id=None, meta=None))]
    fn from_episodes(
        _cls: &Bound<'_, PyType>,
        episodes: &Bound<'_, PyAny>,
        env_id: Option<String>,
        meta: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard("EpisodeSet.from_episodes", || {
            let mut meta = meta_from_py(meta)?;
            if env_id.is_some() {
                meta.env_id = env_id;
            }
            let mut set: Option<defender::EpisodeSet> = None;
            for (i, ep) in episodes.try_iter()?.enumerate() {
                let ep = ep?;
                let what = format!("episode {i}");
                let (obs, act, rew, crashed) = if let Ok(d) = ep.cast::<PyDict>() {
                    let get = |k: &str| required_item(d, k, &what);
                    (get("obs")?, get("act")?, get("rew")?, get("crashed")?)
                } else {
                    ep.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>, Bound<'_, PyAny>, Bound<'_, PyAny>)>()
                        .map_err(|_| {
                        PyTypeError::new_err(format!(
                            "{what}: expected a tuple (obs, act, rew, crashed) or a dict with those keys"
                        ))
                    })?
                };
                let t = read_transitions(&obs, &act, Some(&rew), &format!("{what} "), None)?;
                let (o, a, r, obs_dim, act_dim) = (t.obs, t.act, t.rew, t.obs_dim, t.act_dim);
                let unit = "N + 1 observations for N actions";
                check_rows(&format!("{what} obs"), t.obs_rows, t.act_rows + 1, unit)?;
                check_rows(&format!("{what} rew"), r.len(), t.act_rows, "one reward per action")?;
                if set.is_none() {
                    check_meta_dims(&meta, obs_dim, act_dim)?;
                }
                let set = match &mut set {
                    Some(s) => s,
                    None => set.insert(
                        defender::EpisodeSet::new(obs_dim, act_dim, meta.clone()).map_err(defender_err)?,
                    ),
                };
                if (set.obs_dim(), set.act_dim()) != (obs_dim, act_dim) {
                    return Err(DefenderError::new_err(format!(
                        "episode {i}: dimensions (obs {obs_dim}, act {act_dim}) differ from the first episode's \
                         (obs {}, act {})",
                        set.obs_dim(),
                        set.act_dim()
                    )));
                }
                set.push_episode(&o, &a, &r, crashed.is_truthy()?)
                    .map_err(|e| DefenderError::new_err(format!("episode {i}: {e}")))?;
            }
            set.map(Self::from_inner).ok_or_else(|| {
                DefenderError::new_err("episodes: empty (an episode set needs at least one episode)")
            })
        })
    }

    /// The arrays of the file format: a dict with `obs`, `act`, `rew` (float32), `ep_len` (int64),
    /// `crashed` (bool) and `meta` (a dict).
    fn to_arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.inner;
        let (mut obs, mut act, mut rew) = (Vec::new(), Vec::new(), Vec::new());
        let (mut ep_len, mut crashed) = (Vec::new(), Vec::new());
        for e in s.episodes() {
            obs.extend_from_slice(e.obs);
            act.extend_from_slice(e.act);
            rew.extend_from_slice(e.rew);
            ep_len.push(e.rew.len() as i64);
            crashed.push(e.crashed);
        }
        let d = PyDict::new(py);
        let obs_rows = obs.len() / s.obs_dim();
        let act_rows = act.len() / s.act_dim();
        d.set_item("obs", mat(py, obs, obs_rows, s.obs_dim())?)?;
        d.set_item("act", mat(py, act, act_rows, s.act_dim())?)?;
        d.set_item("rew", numpy::PyArray1::from_vec(py, rew))?;
        d.set_item("ep_len", numpy::PyArray1::from_vec(py, ep_len))?;
        d.set_item("crashed", numpy::PyArray1::from_vec(py, crashed))?;
        d.set_item("meta", meta_to_py(py, s.meta())?)?;
        Ok(d)
    }

    /// Episode `i` as a dict: `obs` [N+1, obs_dim], `act` [N, act_dim], `rew` [N], `crashed`.
    fn episode<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, PyDict>> {
        let n = self.inner.len() as isize;
        let k = if i < 0 { i + n } else { i };
        if !(0..n).contains(&k) {
            return Err(PyIndexError::new_err(format!("episode {i}: the set has {n} episodes")));
        }
        let e = self.inner.episode(k as usize);
        let d = PyDict::new(py);
        d.set_item("obs", mat(py, e.obs.to_vec(), e.rew.len() + 1, e.obs_dim)?)?;
        d.set_item("act", mat(py, e.act.to_vec(), e.rew.len(), e.act_dim)?)?;
        d.set_item("rew", numpy::PyArray1::from_slice(py, e.rew))?;
        d.set_item("crashed", e.crashed)?;
        Ok(d)
    }

    /// The first `n` demonstrations of each group, in file order (`num_demos`).
    fn select_demos(&self, n: &Bound<'_, PyAny>) -> PyResult<Self> {
        let n = crate::checks::whole_arg(n, "select_demos(n)", 1, usize::MAX as u64)? as usize;
        self.inner.select_demos(n).map(Self::from_inner).map_err(defender_err)
    }

    /// `(safe, unsafe)`: episodes that did not crash and that crashed.
    #[getter]
    fn group_sizes(&self) -> (usize, usize) {
        self.inner.group_sizes()
    }

    /// Observation dimension.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim()
    }

    /// Action dimension.
    #[getter]
    fn act_dim(&self) -> usize {
        self.inner.act_dim()
    }

    /// The Gymnasium id recorded in `meta`, if any.
    #[getter]
    fn env_id(&self) -> Option<String> {
        self.inner.meta().env_id.clone()
    }

    /// The `meta` JSON as a dict.
    #[getter]
    fn meta<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        meta_to_py(py, self.inner.meta())
    }

    /// Number of transitions over all episodes.
    #[getter]
    fn transitions(&self) -> usize {
        self.inner.transitions()
    }

    /// The lowest per-step reward (the default `R_task`), or None for an empty set.
    #[getter]
    fn min_reward(&self) -> Option<f32> {
        self.inner.min_reward()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<EpisodeSet>().is_ok_and(|o| {
            let o = &o.get().inner;
            o.obs_dim() == self.inner.obs_dim()
                && o.act_dim() == self.inner.act_dim()
                && o.meta() == self.inner.meta()
                && o.len() == self.inner.len()
                && o.episodes().zip(self.inner.episodes()).all(|(a, b)| {
                    a.obs == b.obs && a.act == b.act && a.rew == b.rew && a.crashed == b.crashed
                })
        })
    }

    fn __repr__(&self) -> String {
        let (safe, unsafe_) = self.inner.group_sizes();
        format!(
            "EpisodeSet(env_id={:?}, episodes={}, safe={safe}, unsafe={unsafe_}, transitions={}, obs_dim={}, act_dim={})",
            self.inner.meta().env_id.as_deref().unwrap_or("?"),
            self.inner.len(),
            self.inner.transitions(),
            self.inner.obs_dim(),
            self.inner.act_dim()
        )
    }

    /// Pickling (for `SubprocVecEnv` / `AsyncVectorEnv` workers): rebuilt from its arrays.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let arrays = slf.get().to_arrays(py)?;
        let from_arrays = slf.get_type().getattr("from_arrays")?;
        let args = (
            arrays.get_item("obs")?,
            arrays.get_item("act")?,
            arrays.get_item("rew")?,
            arrays.get_item("ep_len")?,
            arrays.get_item("crashed")?,
            arrays.get_item("meta")?,
        );
        Ok((from_arrays, args.into_pyobject(py)?.into_any()))
    }
}
