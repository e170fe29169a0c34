//! The episode-set file (SPEC section 8): reading a `.npz` archive with every check its arrays
//! must pass before the set is built, and writing one that numpy reads.

use std::path::Path;

use super::{EpisodeSet, Meta};
use crate::atomic::write_atomic;
use crate::error::{DefenderError, Result};
use crate::npz::{Array, Header, NpzReader, NpzWriter, Values, bad};

impl EpisodeSet {
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

pub(super) fn check_finite(path: &Path, array: &'static str, values: &[f32]) -> Result<()> {
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
    use super::super::tests::small_set;
    use super::*;

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
