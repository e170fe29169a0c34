//! Saving and restoring a [`DynamicsModel`] so that it continues bit for bit.
//!
//! A checkpoint directory holds `dynamics.safetensors` (the network), `dynamics_adam.safetensors`
//! (the optimiser), `dynamics_buffer.bin` (the transition store, `defender-rl`'s replay-buffer
//! format) and `dynamics_state.json` (configuration, normalisation, counters, and the sampling
//! RNG serialised as the agents serialise theirs: `{"seed", "stream", "word_pos"}`).
//!
//! Checkpoints written before the store became a replay buffer (runs started earlier must
//! resume) hold `dynamics_buffer.npz` (`obs`, `act`, `next_obs` in ring order, with `pos` and
//! `len` in the JSON) and the RNG as `rng_seed`, `rng_stream` and `rng_word_pos` (a string).
//! [`DynamicsModel::load`] reads both; [`DynamicsModel::save`] writes the current format.

use std::path::Path;

use defender_nn::{Adam, Mlp};
use defender_rl::Transition;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::normaliser::{Normaliser, Stats};
use super::{DynamicsConfig, DynamicsModel, PredictionError};
use crate::atomic::{commit_file, write_atomic};
use crate::error::{DefenderError, Result};
use crate::npz::{NpzReader, Values};

const NET_FILE: &str = "dynamics.safetensors";
const ADAM_FILE: &str = "dynamics_adam.safetensors";
const BUFFER_FILE: &str = "dynamics_buffer.bin";
const LEGACY_BUFFER_FILE: &str = "dynamics_buffer.npz";
const STATE_FILE: &str = "dynamics_state.json";

/// What `dynamics_state.json` holds.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SavedState {
    config: DynamicsConfig,
    obs_dim: usize,
    act_dim: usize,
    input_stats: Stats,
    delta_stats: Stats,
    error: PredictionError,
    real_steps: u64,
    gradient_steps: u64,
    last_loss: f32,
    /// The sampling RNG (current format).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rng: Option<ChaCha8Rng>,
    /// The earlier format's fields (see the module's documentation); absent in the current one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pos: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    len: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rng_seed: Option<Vec<u8>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rng_stream: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rng_word_pos: Option<String>,
}

impl DynamicsModel {
    /// Saves the whole state (network, optimiser, transition store, normalisation, RNG,
    /// counters) into directory `dir` (created if needed), each file written atomically.
    ///
    /// # Errors
    /// An I/O error.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<()> {
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|e| DefenderError::io(dir, e))?;
        commit_file(&dir.join(NET_FILE), |tmp| Ok(self.net.save_safetensors(tmp)?))?;
        commit_file(&dir.join(ADAM_FILE), |tmp| Ok(self.adam.save_safetensors(tmp)?))?;
        let buffer = dir.join(BUFFER_FILE);
        commit_file(&buffer, |tmp| {
            self.store
                .save(tmp)
                .map_err(|e| DefenderError::Checkpoint { path: buffer.clone(), what: e.to_string() })
        })?;
        let (input, delta) = self.normaliser.stats();
        let state = SavedState {
            config: self.config.clone(),
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
            input_stats: input.clone(),
            delta_stats: delta.clone(),
            error: self.error,
            real_steps: self.real_steps,
            gradient_steps: self.gradient_steps,
            last_loss: self.last_loss,
            rng: Some(self.rng.clone()),
            pos: None,
            len: None,
            rng_seed: None,
            rng_stream: None,
            rng_word_pos: None,
        };
        let json = dir.join(STATE_FILE);
        write_atomic(&json, |w| {
            serde_json::to_writer_pretty(&mut *w, &state)
                .map_err(|e| DefenderError::Checkpoint { path: json.clone(), what: e.to_string() })
        })?;
        // A directory reused from an earlier format must not keep a store that is no longer read.
        match std::fs::remove_file(dir.join(LEGACY_BUFFER_FILE)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(DefenderError::io(dir.join(LEGACY_BUFFER_FILE), e))
            }
            _ => Ok(()),
        }
    }

    /// Restores a model saved by [`DynamicsModel::save`] (or by the earlier format); it
    /// continues bit for bit as the saved one would have.
    ///
    /// # Errors
    /// Missing or inconsistent files, naming the file.
    pub fn load(dir: impl AsRef<Path>) -> Result<Self> {
        let dir = dir.as_ref();
        let json = dir.join(STATE_FILE);
        let text = std::fs::read_to_string(&json).map_err(|e| DefenderError::io(&json, e))?;
        let bad = |what: String| DefenderError::Checkpoint { path: json.clone(), what };
        let mut s: SavedState = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        s.config.validate()?;
        let rng = match s.rng.take() {
            Some(rng) => rng,
            None => legacy_rng(&s).map_err(bad)?,
        };
        let net = Mlp::load_safetensors(dir.join(NET_FILE))?;
        let widths = super::widths(s.obs_dim, s.act_dim, &s.config);
        if net.widths() != widths.as_slice() {
            return Err(bad(format!(
                "network widths {:?} do not match the saved config {widths:?}",
                net.widths()
            )));
        }
        let adam = Adam::load_safetensors(dir.join(ADAM_FILE), &net)?;
        let normaliser = Normaliser::from_stats(s.input_stats, s.delta_stats);
        if normaliser.dims() != (s.obs_dim + s.act_dim, s.obs_dim) {
            return Err(bad(format!("normalisation statistics of dimensions {:?}", normaliser.dims())));
        }
        let mut m = Self::assemble(s.config, s.obs_dim, s.act_dim, net, adam, rng)?;
        match (s.pos, s.len) {
            (None, None) => {
                let path = dir.join(BUFFER_FILE);
                m.store.load(&path).map_err(|e| DefenderError::Checkpoint { path, what: e.to_string() })?;
            }
            (Some(pos), Some(len)) => load_legacy_store(&mut m, &dir.join(LEGACY_BUFFER_FILE), pos, len)?,
            _ => return Err(bad("pos and len go together".into())),
        }
        m.normaliser = normaliser;
        m.error = s.error;
        m.real_steps = s.real_steps;
        m.gradient_steps = s.gradient_steps;
        m.last_loss = s.last_loss;
        Ok(m)
    }
}

/// The sampling RNG of an earlier checkpoint.
fn legacy_rng(s: &SavedState) -> std::result::Result<ChaCha8Rng, String> {
    let (Some(seed), Some(stream), Some(word_pos)) = (&s.rng_seed, s.rng_stream, &s.rng_word_pos) else {
        return Err("no sampling RNG (`rng`, or `rng_seed`, `rng_stream` and `rng_word_pos`)".into());
    };
    let seed: [u8; 32] = seed.as_slice().try_into().map_err(|_| "rng_seed must be 32 bytes".to_string())?;
    let mut rng = ChaCha8Rng::from_seed(seed);
    rng.set_stream(stream);
    rng.set_word_pos(word_pos.parse().map_err(|e| format!("rng_word_pos: {e}"))?);
    Ok(rng)
}

/// Fills the (empty) store of `m` from an earlier checkpoint's `.npz`, rows at the indices they
/// had, the next write at `pos`: sampling then draws the same transitions.
fn load_legacy_store(m: &mut DynamicsModel, path: &Path, pos: usize, len: usize) -> Result<()> {
    let bad = |what: String| DefenderError::Checkpoint { path: path.to_path_buf(), what };
    let capacity = m.store.capacity();
    let consistent = if len == capacity { pos < capacity } else { len < capacity && pos == len };
    if !consistent {
        return Err(bad(format!("pos {pos} and len {len} do not fit a buffer of {capacity}")));
    }
    let mut npz = NpzReader::open(path)?;
    let mut arrays = Vec::with_capacity(3);
    for (name, width) in [("obs", m.obs_dim), ("act", m.act_dim), ("next_obs", m.obs_dim)] {
        let arr = npz.read(name)?.ok_or_else(|| bad(format!("array '{name}' missing")))?;
        match arr.values {
            Values::F32(v) if arr.shape == [len, width] => arrays.push(v),
            _ => return Err(bad(format!("array '{name}' is not float32 [{len}, {width}]"))),
        }
    }
    let (o, a) = (m.obs_dim, m.act_dim);
    let to_f64 = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    // Rows 0..len in order leave the next write at `len % capacity`; a full ring then rewrites
    // rows 0..pos with themselves, which moves the next write to `pos`.
    let rows = (0..len).chain(if len == capacity { 0..pos } else { 0..0 });
    for i in rows {
        let (obs, next) = (to_f64(&arrays[0][i * o..(i + 1) * o]), to_f64(&arrays[2][i * o..(i + 1) * o]));
        let t = Transition {
            obs: &obs,
            action: &arrays[1][i * a..(i + 1) * a],
            reward: 0.0,
            cost: 0.0,
            next_obs: &next,
            terminated: false,
            truncated: false,
        };
        m.store.push(&t).map_err(|e| bad(e.to_string()))?;
    }
    Ok(())
}
