//! Episode sets (SPEC sections 1 and 8): demonstration sets and recorded episode sets, their
//! `.npz` file format, validation, groups and sequences.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_atomic;
use crate::error::{DefenderError, Result};
use crate::npz::{Array, Header, NpzReader, NpzWriter, Values, bad};
use crate::strategy::Mode;

/// The `meta` array of an episode-set file: UTF-8 JSON describing the set. Every field is
/// optional on read (a file written by hand may carry none); the ones present must agree with the
/// arrays. Keys this struct does not know are kept in `extra` and written back.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// The Gymnasium id of the environment (e.g. `Hopper-v5`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_id: Option<String>,
    /// Observation dimension.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obs_dim: Option<usize>,
    /// Action dimension.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub act_dim: Option<usize>,
    /// How the set was made (free text: program, agent, seed, date ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<String>,
    /// Any other keys.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// A set of episodes: every episode's observations (the final one included), actions, rewards and
/// whether it crashed. Stored as the concatenated arrays of SPEC section 8, in f32.
///
/// A *demonstration set* is an episode set whose crashed episodes form the unsafe group and the
/// others the safe group; a *recorded episode set* is the input of the offline ablation.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeSet {
    source: PathBuf,
    obs_dim: usize,
    act_dim: usize,
    obs: Vec<f32>,
    act: Vec<f32>,
    rew: Vec<f32>,
    ep_len: Vec<usize>,
    crashed: Vec<bool>,
    /// Row offsets of each episode in `obs` (and, minus the episode index, in `act` / `rew`).
    obs_start: Vec<usize>,
    meta: Meta,
}

/// One episode of a set, borrowed.
#[derive(Debug, Clone, Copy)]
pub struct Episode<'a> {
    /// Position in the set (file order).
    pub index: usize,
    /// `N + 1` observations, row-major `[(N + 1) * obs_dim]`.
    pub obs: &'a [f32],
    /// `N` actions, row-major `[N * act_dim]`.
    pub act: &'a [f32],
    /// `N` rewards.
    pub rew: &'a [f32],
    /// The environment terminated it before the horizon.
    pub crashed: bool,
    /// Observation dimension.
    pub obs_dim: usize,
    /// Action dimension.
    pub act_dim: usize,
}

impl Episode<'_> {
    /// Number of transitions `N`.
    pub fn len(&self) -> usize {
        self.rew.len()
    }

    /// Whether the episode has no transition (never true for a validated set).
    pub fn is_empty(&self) -> bool {
        self.rew.is_empty()
    }

    /// Observation `i` (`0 ..= N`).
    pub fn observation(&self, i: usize) -> &[f32] {
        &self.obs[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    /// Action `i` (`0 .. N`).
    pub fn action(&self, i: usize) -> &[f32] {
        &self.act[i * self.act_dim..(i + 1) * self.act_dim]
    }

    /// Number of elements of the episode's sequence: `N + 1` in state mode, `N` in state-action
    /// mode (SPEC section 1).
    pub fn sequence_len(&self, mode: Mode) -> usize {
        match mode {
            Mode::State => self.len() + 1,
            Mode::StateAction => self.len(),
        }
    }

    /// The episode's sequence (SPEC section 1), row-major: `[o_0 .. o_N]` in state mode,
    /// `[concat(o_i, a_i) for i < N]` in state-action mode.
    pub fn sequence(&self, mode: Mode) -> Vec<f32> {
        match mode {
            Mode::State => self.obs.to_vec(),
            Mode::StateAction => {
                let mut out = Vec::with_capacity(self.len() * (self.obs_dim + self.act_dim));
                for i in 0..self.len() {
                    out.extend_from_slice(self.observation(i));
                    out.extend_from_slice(self.action(i));
                }
                out
            }
        }
    }
}

const MEMORY: &str = "<memory>";

impl EpisodeSet {
    /// An empty set for an environment with these dimensions; fill it with
    /// [`EpisodeSet::push_episode`]. `meta.obs_dim` / `meta.act_dim` are set from the arguments.
    ///
    /// # Errors
    /// A dimension is zero.
    pub fn new(obs_dim: usize, act_dim: usize, mut meta: Meta) -> Result<Self> {
        if obs_dim == 0 || act_dim == 0 {
            return Err(DefenderError::Config(format!(
                "an episode set needs obs_dim >= 1 and act_dim >= 1, got {obs_dim} and {act_dim}"
            )));
        }
        meta.obs_dim = Some(obs_dim);
        meta.act_dim = Some(act_dim);
        Ok(Self {
            source: PathBuf::from(MEMORY),
            obs_dim,
            act_dim,
            obs: Vec::new(),
            act: Vec::new(),
            rew: Vec::new(),
            ep_len: Vec::new(),
            crashed: Vec::new(),
            obs_start: Vec::new(),
            meta,
        })
    }

    /// Appends one episode of `N >= 1` transitions: `N + 1` observations (the final one included),
    /// `N` actions and `N` rewards, all row-major f32.
    ///
    /// # Errors
    /// Lengths that do not fit `N` transitions of this set's dimensions, or non-finite values; the
    /// set is unchanged then.
    pub fn push_episode(&mut self, obs: &[f32], act: &[f32], rew: &[f32], crashed: bool) -> Result<()> {
        let n = rew.len();
        let path = self.source.clone();
        if n == 0 {
            return Err(bad(&path, "rew", "at least one transition per episode", "0 rewards"));
        }
        if obs.len() != (n + 1) * self.obs_dim {
            return Err(bad(
                &path,
                "obs",
                &format!(
                    "{} values ({} observations of dim {})",
                    (n + 1) * self.obs_dim,
                    n + 1,
                    self.obs_dim
                ),
                format!("{}", obs.len()),
            ));
        }
        if act.len() != n * self.act_dim {
            return Err(bad(
                &path,
                "act",
                &format!("{} values ({n} actions of dim {})", n * self.act_dim, self.act_dim),
                format!("{}", act.len()),
            ));
        }
        for (name, v) in [("obs", obs), ("act", act), ("rew", rew)] {
            check_finite(&path, name, v)?;
        }
        self.obs_start.push(self.obs.len() / self.obs_dim);
        self.obs.extend_from_slice(obs);
        self.act.extend_from_slice(act);
        self.rew.extend_from_slice(rew);
        self.ep_len.push(n);
        self.crashed.push(crashed);
        Ok(())
    }

    /// [`EpisodeSet::push_episode`] for f64 data as environments produce it (stored as f32).
    ///
    /// # Errors
    /// As [`EpisodeSet::push_episode`].
    pub fn push_episode_f64(&mut self, obs: &[f64], act: &[f64], rew: &[f64], crashed: bool) -> Result<()> {
        let f = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        self.push_episode(&f(obs), &f(act), &f(rew), crashed)
    }

    /// Where the set came from (its file, or `<memory>`); errors name it.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// The set's metadata.
    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    /// The set's metadata, mutably (e.g. to add provenance before saving).
    pub fn meta_mut(&mut self) -> &mut Meta {
        &mut self.meta
    }

    /// Number of episodes `E`.
    pub fn len(&self) -> usize {
        self.ep_len.len()
    }

    /// Whether the set has no episode.
    pub fn is_empty(&self) -> bool {
        self.ep_len.is_empty()
    }

    /// Total number of transitions.
    pub fn transitions(&self) -> usize {
        self.rew.len()
    }

    /// Episode `i` (file order).
    ///
    /// # Panics
    /// `i >= self.len()`.
    pub fn episode(&self, i: usize) -> Episode<'_> {
        let n = self.ep_len[i];
        let o = self.obs_start[i];
        let a = o - i; // every earlier episode has one more observation than actions
        Episode {
            index: i,
            obs: &self.obs[o * self.obs_dim..(o + n + 1) * self.obs_dim],
            act: &self.act[a * self.act_dim..(a + n) * self.act_dim],
            rew: &self.rew[a..a + n],
            crashed: self.crashed[i],
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
        }
    }

    /// All episodes in file order.
    pub fn episodes(&self) -> impl ExactSizeIterator<Item = Episode<'_>> + '_ {
        (0..self.len()).map(|i| self.episode(i))
    }

    /// The safe group: episodes with `crashed = false`, in file order (SPEC section 1).
    pub fn safe(&self) -> impl Iterator<Item = Episode<'_>> + '_ {
        self.episodes().filter(|e| !e.crashed)
    }

    /// The unsafe group: episodes with `crashed = true`, in file order.
    pub fn unsafe_(&self) -> impl Iterator<Item = Episode<'_>> + '_ {
        self.episodes().filter(|e| e.crashed)
    }

    /// Sizes of the (safe, unsafe) groups.
    pub fn group_sizes(&self) -> (usize, usize) {
        let unsafe_ = self.crashed.iter().filter(|&&c| c).count();
        (self.len() - unsafe_, unsafe_)
    }

    /// Checks that both groups are non-empty, as a demonstration set must be.
    ///
    /// # Errors
    /// [`DefenderError::MissingGroup`] naming the file and the empty group.
    pub fn require_both_groups(&self) -> Result<()> {
        let (safe, unsafe_) = self.group_sizes();
        if safe == 0 {
            return Err(DefenderError::MissingGroup {
                path: self.source.clone(),
                group: "safe",
                crashed: false,
            });
        }
        if unsafe_ == 0 {
            return Err(DefenderError::MissingGroup {
                path: self.source.clone(),
                group: "unsafe",
                crashed: true,
            });
        }
        Ok(())
    }

    /// Checks the set against an environment's dimensions and id (`meta.env_id`, when the file
    /// names one).
    ///
    /// # Errors
    /// [`DefenderError::InvalidArray`] naming the array whose dimension differs, or the `meta`
    /// whose env id differs.
    pub fn check_env(&self, env_id: &str, obs_dim: usize, act_dim: usize) -> Result<()> {
        if self.obs_dim != obs_dim {
            return Err(bad(
                &self.source,
                "obs",
                &format!("{obs_dim} columns (the observation dimension of {env_id})"),
                format!("{} columns", self.obs_dim),
            ));
        }
        if self.act_dim != act_dim {
            return Err(bad(
                &self.source,
                "act",
                &format!("{act_dim} columns (the action dimension of {env_id})"),
                format!("{} columns", self.act_dim),
            ));
        }
        match &self.meta.env_id {
            Some(id) if id != env_id => {
                Err(bad(&self.source, "meta", &format!("env_id \"{env_id}\""), format!("env_id \"{id}\"")))
            }
            _ => Ok(()),
        }
    }

    /// The demonstrations a run uses: the first `n` episodes of each group in file order (the rule
    /// behind `--num-demos N`; files list demonstrations in the order they were made). The result
    /// keeps file order and names the same source.
    ///
    /// # Errors
    /// [`DefenderError::NotEnoughDemos`] if a group has fewer than `n`; a config error for `n = 0`.
    pub fn select_demos(&self, n: usize) -> Result<EpisodeSet> {
        if n == 0 {
            return Err(DefenderError::Config("the number of demonstrations per group must be >= 1".into()));
        }
        let (safe, unsafe_) = self.group_sizes();
        for (group, available) in [("safe", safe), ("unsafe", unsafe_)] {
            if available < n {
                return Err(DefenderError::NotEnoughDemos {
                    path: self.source.clone(),
                    setting: "num_demos",
                    group,
                    asked: n,
                    available,
                });
            }
        }
        let mut out = EpisodeSet::new(self.obs_dim, self.act_dim, self.meta.clone())?;
        out.source = self.source.clone();
        let (mut s, mut u) = (0, 0);
        for e in self.episodes() {
            let count = if e.crashed { &mut u } else { &mut s };
            if *count < n {
                *count += 1;
                out.push_episode(e.obs, e.act, e.rew, e.crashed)?;
            }
        }
        Ok(out)
    }

    /// The lowest per-step reward over all episodes (both groups): the default `R_task`
    /// (SPEC section 5). `None` for an empty set.
    pub fn min_reward(&self) -> Option<f32> {
        self.rew.iter().copied().reduce(f32::min)
    }

    /// Reads an episode-set file (SPEC section 8) and validates it.
    ///
    /// Accepted on read: float32 or float64 `obs` / `act` / `rew`; `ep_len` of any integer type
    /// (int64 is what we write); C or Fortran order. An optional `meta` must be uint8 UTF-8 JSON
    /// (an object); dimensions it states must match the arrays.
    ///
    /// # Errors
    /// [`DefenderError::InvalidArray`] naming the file, the array and what was expected (missing
    /// array, wrong dtype or shape, shapes that do not add up, NaN or infinite values, an empty
    /// set, `N_i < 1`); [`DefenderError::Io`] / [`DefenderError::Format`] for unreadable files.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let mut npz = NpzReader::open(path)?;
        // Every header is checked (against its entry's size, then against the others and
        // `ep_len`) before any large array is inflated: a file cannot make us allocate more than
        // its own arrays hold, nor more than its shapes add up to.
        let mut need = |name: &'static str| -> Result<Header> {
            npz.header(name)?.ok_or_else(|| bad(path, name, "an array of this name in the archive", "none"))
        };
        let obs_h = need("obs")?;
        let act_h = need("act")?;
        let rew_h = need("rew")?;
        let ep_len_h = need("ep_len")?;
        let crashed_h = need("crashed")?;

        let e = match ep_len_h.shape.as_slice() {
            [_] if !ep_len_h.is_int() => return Err(bad(path, "ep_len", "dtype int64", ep_len_h.descr)),
            [e] => *e,
            _ => return Err(bad(path, "ep_len", "a 1-D array [E]", format!("shape {:?}", ep_len_h.shape))),
        };
        if e == 0 {
            return Err(bad(path, "ep_len", "at least one episode (an empty set is refused)", "shape [0]"));
        }
        if !crashed_h.is_bool() {
            return Err(bad(path, "crashed", "dtype bool", crashed_h.descr));
        }
        match crashed_h.shape.as_slice() {
            [len] if *len == e => {}
            [_] => {
                return Err(bad(
                    path,
                    "crashed",
                    &format!("shape [{e}] (one flag per episode)"),
                    format!("shape {:?}", crashed_h.shape),
                ));
            }
            _ => {
                return Err(bad(
                    path,
                    "crashed",
                    &format!("a 1-D array [{e}]"),
                    format!("shape {:?}", crashed_h.shape),
                ));
            }
        }
        // Each episode has at least one reward: more episodes than rewards cannot add up.
        if e > rew_h.len {
            return Err(bad(
                path,
                "ep_len",
                &format!(
                    "at most {} episodes (one reward at least per episode; rew has {})",
                    rew_h.len, rew_h.len
                ),
                format!("shape [{e}]"),
            ));
        }
        let ep_len = match npz.read("ep_len")?.map(|a| a.values) {
            Some(Values::Int(v)) => v,
            Some(Values::U8(v)) => v.into_iter().map(i64::from).collect(),
            _ => return Err(bad(path, "ep_len", "dtype int64", ep_len_h.descr)),
        };
        if let Some((i, n)) = ep_len.iter().enumerate().find(|(_, n)| **n < 1) {
            return Err(bad(
                path,
                "ep_len",
                "N_i >= 1 transitions per episode",
                format!("ep_len[{i}] = {n}"),
            ));
        }
        let ep_len: Vec<usize> =
            ep_len.into_iter().map(|n| usize::try_from(n).unwrap_or(usize::MAX)).collect();
        let total = ep_len.iter().try_fold(0usize, |acc, &n| acc.checked_add(n));
        let Some((transitions, observations)) = total.and_then(|t| Some((t, t.checked_add(e)?))) else {
            return Err(bad(
                path,
                "ep_len",
                "transition counts whose sum fits in 64 bits",
                "a sum that overflows",
            ));
        };
        let obs_dim = float_matrix(path, "obs", &obs_h, observations, "sum(N_i + 1)")?;
        let act_dim = float_matrix(path, "act", &act_h, transitions, "sum(N_i)")?;
        match rew_h.shape.as_slice() {
            [len] if *len == transitions && rew_h.is_float() => {}
            [len] if *len == transitions => {
                return Err(bad(path, "rew", "dtype float32 (or float64)", rew_h.descr));
            }
            _ => {
                return Err(bad(
                    path,
                    "rew",
                    &format!("shape [{transitions}] (sum(N_i))"),
                    format!("shape {:?}", rew_h.shape),
                ));
            }
        }
        // Every shape adds up: now the data.
        let mut read = |name: &'static str| -> Result<Array> {
            npz.read(name)?.ok_or_else(|| bad(path, name, "an array of this name in the archive", "none"))
        };
        let obs = floats(path, "obs", read("obs")?.values, &obs_h.descr)?;
        let act = floats(path, "act", read("act")?.values, &act_h.descr)?;
        let rew = floats(path, "rew", read("rew")?.values, &rew_h.descr)?;
        let crashed = match read("crashed")?.values {
            Values::Bool(v) => v,
            _ => return Err(bad(path, "crashed", "dtype bool", crashed_h.descr)),
        };
        let meta = npz.read("meta")?;
        for (name, v) in [("obs", &obs), ("act", &act), ("rew", &rew)] {
            check_finite(path, name, v)?;
        }
        let meta = match meta {
            None => Meta::default(),
            Some(m) => parse_meta(path, m)?,
        };
        for (key, value, dim) in [("obs_dim", meta.obs_dim, obs_dim), ("act_dim", meta.act_dim, act_dim)] {
            if let Some(v) = value.filter(|&v| v != dim) {
                return Err(bad(
                    path,
                    "meta",
                    &format!("{key} = {dim} (as the arrays have)"),
                    format!("{key} = {v}"),
                ));
            }
        }
        let mut obs_start = Vec::with_capacity(e);
        let mut row = 0;
        for &n in &ep_len {
            obs_start.push(row);
            row += n + 1;
        }
        let mut meta = meta;
        meta.obs_dim = Some(obs_dim);
        meta.act_dim = Some(act_dim);
        Ok(Self {
            source: path.to_owned(),
            obs_dim,
            act_dim,
            obs,
            act,
            rew,
            ep_len,
            crashed,
            obs_start,
            meta,
        })
    }

    /// Writes the set in the format of SPEC section 8 (float32 arrays, int64 `ep_len`, bool
    /// `crashed`, uint8 JSON `meta`), atomically (`NAME.tmp`, then rename). `np.load(path)` reads it.
    ///
    /// # Errors
    /// An empty set, or an I/O error.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        if self.is_empty() {
            return Err(bad(path, "ep_len", "at least one episode (an empty set is refused)", "no episodes"));
        }
        let meta = serde_json::to_vec(&self.meta)
            .map_err(|e| DefenderError::Format { path: path.to_owned(), what: format!("meta: {e}") })?;
        let ep_len: Vec<i64> = self.ep_len.iter().map(|&n| n as i64).collect();
        write_atomic(path, |w| {
            let mut npz = NpzWriter::new(w, path);
            npz.write("obs", &[self.obs.len() / self.obs_dim, self.obs_dim], &self.obs)?;
            npz.write("act", &[self.act.len() / self.act_dim, self.act_dim], &self.act)?;
            npz.write("rew", &[self.rew.len()], &self.rew)?;
            npz.write("ep_len", &[ep_len.len()], &ep_len)?;
            npz.write("crashed", &[self.crashed.len()], &self.crashed)?;
            npz.write("meta", &[meta.len()], &meta)?;
            npz.finish()?;
            Ok(())
        })
    }
}

fn check_finite(path: &Path, array: &'static str, values: &[f32]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(bad(
            path,
            array,
            "finite values (no NaN or infinity)",
            format!("{} at flat index {i}", values[i]),
        )),
    }
}

fn floats(path: &Path, array: &'static str, values: Values, descr: &str) -> Result<Vec<f32>> {
    match values {
        Values::F32(v) => Ok(v),
        Values::F64(v) => {
            // f64 values beyond f32's range would become infinite: report them as such.
            if let Some(i) = v.iter().position(|x| x.is_finite() && (*x as f32).is_infinite()) {
                return Err(bad(
                    path,
                    array,
                    "values within float32 range",
                    format!("{} at flat index {i}", v[i]),
                ));
            }
            Ok(v.into_iter().map(|x| x as f32).collect())
        }
        _ => Err(bad(path, array, "dtype float32 (or float64)", descr)),
    }
}

fn float_matrix(path: &Path, array: &'static str, h: &Header, rows: usize, rule: &str) -> Result<usize> {
    match h.shape.as_slice() {
        [r, c] if *r == rows && *c >= 1 && h.is_float() => Ok(*c),
        [r, c] if *r == rows && *c >= 1 => {
            Err(bad(path, array, "dtype float32 (or float64)", h.descr.clone()))
        }
        [_, c] if *c >= 1 => Err(bad(
            path,
            array,
            &format!("{rows} rows ({rule} over ep_len)"),
            format!("shape {:?}", h.shape),
        )),
        _ => Err(bad(
            path,
            array,
            &format!("a 2-D array [{rule}, dim] with dim >= 1"),
            format!("shape {:?}", h.shape),
        )),
    }
}

fn parse_meta(path: &Path, m: Array) -> Result<Meta> {
    let bytes = match (m.shape.len(), m.values) {
        (1, Values::U8(b)) => b,
        (1, _) => return Err(bad(path, "meta", "dtype uint8 (UTF-8 JSON bytes)", m.descr)),
        _ => return Err(bad(path, "meta", "a 1-D uint8 array", format!("shape {:?}", m.shape))),
    };
    let text = String::from_utf8(bytes)
        .map_err(|e| bad(path, "meta", "UTF-8 text", format!("invalid UTF-8 ({e})")))?;
    serde_json::from_str(&text).map_err(|e| {
        bad(path, "meta", "a JSON object (env_id, obs_dim, act_dim, provenance)", format!("{e}"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn small_set() -> EpisodeSet {
        let mut set =
            EpisodeSet::new(2, 1, Meta { env_id: Some("Test-v0".into()), ..Meta::default() }).unwrap();
        set.push_episode(&[0., 0., 1., 1., 2., 2.], &[0.5, -0.5], &[1.0, 2.0], false).unwrap();
        set.push_episode(&[5., 5., 6., 6.], &[0.1], &[-3.0], true).unwrap();
        set.push_episode(&[7., 7., 8., 8., 9., 9., 10., 10.], &[0.2, 0.3, 0.4], &[0.0, 1.0, 2.0], false)
            .unwrap();
        set
    }

    #[test]
    fn episodes_groups_and_sequences() {
        let set = small_set();
        assert_eq!(set.len(), 3);
        assert_eq!(set.transitions(), 6);
        let e = set.episode(2);
        assert_eq!(e.len(), 3);
        assert_eq!(e.observation(3), &[10., 10.]);
        assert_eq!(e.action(1), &[0.3]);
        assert_eq!(e.rew, &[0.0, 1.0, 2.0]);
        assert_eq!(e.sequence(Mode::State).len(), 4 * 2);
        assert_eq!(e.sequence_len(Mode::StateAction), 3);
        assert_eq!(e.sequence(Mode::StateAction), vec![7., 7., 0.2, 8., 8., 0.3, 9., 9., 0.4]);
        assert_eq!(set.group_sizes(), (2, 1));
        assert_eq!(set.safe().map(|e| e.index).collect::<Vec<_>>(), [0, 2]);
        assert_eq!(set.unsafe_().map(|e| e.index).collect::<Vec<_>>(), [1]);
        assert_eq!(set.min_reward(), Some(-3.0));
        set.require_both_groups().unwrap();
    }

    #[test]
    fn selecting_demos_takes_the_first_n_of_each_group() {
        let set = small_set();
        let one = set.select_demos(1).unwrap();
        assert_eq!(one.len(), 2);
        assert_eq!(one.episode(0).obs, set.episode(0).obs);
        assert_eq!(one.episode(1).obs, set.episode(1).obs);
        let err = set.select_demos(2).unwrap_err().to_string();
        assert!(err.contains("num_demos asks for 2") && err.contains("unsafe group has only 1"), "{err}");
        assert!(set.select_demos(0).is_err());
    }

    #[test]
    fn pushing_a_bad_episode_is_refused() {
        let mut set = small_set();
        assert!(set.push_episode(&[0., 0.], &[], &[], false).is_err(), "no transition");
        assert!(set.push_episode(&[0., 0., 1.], &[0.], &[0.], false).is_err(), "obs length");
        assert!(set.push_episode(&[0., 0., 1., 1.], &[0., 1.], &[0.], false).is_err(), "act length");
        let err = set.push_episode(&[0., f32::NAN, 1., 1.], &[0.], &[0.], false).unwrap_err().to_string();
        assert!(err.contains("'obs'") && err.contains("finite"), "{err}");
        assert_eq!(set.len(), 3, "unchanged");
    }

    #[test]
    fn missing_groups_and_env_mismatches_are_named() {
        let mut only_safe = EpisodeSet::new(2, 1, Meta::default()).unwrap();
        only_safe.push_episode(&[0., 0., 1., 1.], &[0.], &[0.], false).unwrap();
        let err = only_safe.require_both_groups().unwrap_err().to_string();
        assert!(err.contains("unsafe group is empty"), "{err}");
        let set = small_set();
        set.check_env("Test-v0", 2, 1).unwrap();
        assert!(set.check_env("Test-v0", 3, 1).unwrap_err().to_string().contains("'obs'"));
        assert!(set.check_env("Test-v0", 2, 2).unwrap_err().to_string().contains("'act'"));
        assert!(set.check_env("Other-v0", 2, 1).unwrap_err().to_string().contains("Other-v0"));
    }

    #[test]
    fn save_and_load_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("set.npz");
        let mut set = small_set();
        set.meta_mut().provenance = Some("unit test".into());
        set.meta_mut().extra.insert("seed".into(), serde_json::json!(7));
        set.save(&path).unwrap();
        let back = EpisodeSet::load(&path).unwrap();
        assert_eq!(back.source(), path.as_path());
        assert_eq!(back.obs, set.obs);
        assert_eq!(back.act, set.act);
        assert_eq!(back.rew, set.rew);
        assert_eq!(back.ep_len, set.ep_len);
        assert_eq!(back.crashed, set.crashed);
        assert_eq!(back.meta, set.meta);
        assert_eq!(back.episode(2).obs, set.episode(2).obs);
    }
}
