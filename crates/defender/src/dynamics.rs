//! The dynamics model of SPEC section 5: an MLP `obs+act -> 256 -> 256 -> obs` (ReLU) that
//! supplies the next observation of a filtered step.
//!
//! What it learns: the network maps the normalised input `[(s - mu_s) / sd_s, (a - mu_a) / sd_a]`
//! to the normalised change `(s' - s - mu_d) / sd_d`, with an L2 (mean squared error) loss; the
//! prediction is `s + mu_d + sd_d * net(...)`. Predicting the change from normalised inputs is
//! the usual way to make one learning rate fit observations of very different scales; SPEC
//! section 5 allows it. The statistics are running means and standard deviations (Welford, f64)
//! of every real transition added, floored at 1e-4.
//!
//! How it learns: Adam (lr 3e-4), batches of 256 drawn uniformly with replacement from its own
//! preallocated ring buffer of real transitions only (never its own predictions), by default
//! one gradient step per real environment step (`train_freq` / `gradient_steps` change that).
//! Before training on a fresh transition it predicts it, and the error of that prediction (MSE
//! over the observation's components, in raw units) is tracked: an honest held-out error.

use std::path::Path;

use defender_nn::faer::{MatMut, MatRef};
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism, mse_loss_grad};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::atomic::{commit_file, write_atomic};
use crate::error::{DefenderError, Result};
use crate::npz::{NpzReader, NpzWriter, Values};

/// Hyperparameters of the dynamics model (SPEC section 5's values by default).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsConfig {
    /// Hidden layer widths.
    pub hidden: Vec<usize>,
    /// Adam learning rate.
    pub learning_rate: f32,
    /// Transitions per gradient step.
    pub batch_size: usize,
    /// Capacity of the transition buffer (oldest transitions are overwritten).
    pub buffer_size: usize,
    /// Real transitions to collect before the first gradient step.
    pub learning_starts: usize,
    /// Train every `train_freq` real steps ...
    pub train_freq: usize,
    /// ... with this many gradient steps.
    pub gradient_steps: usize,
    /// Weight of the newest prediction error in its exponential moving average.
    pub error_ema_alpha: f64,
    /// [`DefenderEnv`](crate::DefenderEnv) trains the model on a thread of its own, concurrently
    /// with the agent's update (another core), with the same result bit for bit; off by default
    /// (one run, one thread). The model alone ignores it.
    pub background: bool,
}

impl Default for DynamicsConfig {
    fn default() -> Self {
        Self {
            hidden: vec![256, 256],
            learning_rate: 3e-4,
            batch_size: 256,
            buffer_size: 1_000_000,
            learning_starts: 1,
            train_freq: 1,
            gradient_steps: 1,
            error_ema_alpha: 0.01,
            background: false,
        }
    }
}

impl DynamicsConfig {
    fn check(&self) -> Result<()> {
        let bad = |what: &str| Err(DefenderError::Config(format!("dynamics: {what}")));
        if self.hidden.contains(&0) {
            return bad("hidden widths must be >= 1");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return bad("learning_rate must be > 0");
        }
        if self.batch_size == 0 || self.buffer_size == 0 || self.train_freq == 0 {
            return bad("batch_size, buffer_size and train_freq must be >= 1");
        }
        if !(0.0..=1.0).contains(&self.error_ema_alpha) || self.error_ema_alpha == 0.0 {
            return bad("error_ema_alpha must be in (0, 1]");
        }
        Ok(())
    }
}

/// The model's one-step prediction error on fresh transitions (predicted before training on
/// them), as mean squared error over the observation's components, raw units.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PredictionError {
    /// Transitions measured.
    pub count: u64,
    /// The latest error.
    pub last: f64,
    /// Exponential moving average (`error_ema_alpha`); equals `last` after the first.
    pub ema: f64,
    /// Mean over all transitions measured.
    pub mean: f64,
}

/// Running mean and variance per component (Welford).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Stats {
    count: u64,
    mean: Vec<f64>,
    m2: Vec<f64>,
}

impl Stats {
    fn new(dim: usize) -> Self {
        Self { count: 0, mean: vec![0.0; dim], m2: vec![0.0; dim] }
    }

    fn add(&mut self, x: impl Iterator<Item = f64>) {
        self.count += 1;
        let n = self.count as f64;
        for ((m, s), v) in self.mean.iter_mut().zip(&mut self.m2).zip(x) {
            let d = v - *m;
            *m += d / n;
            *s += d * (v - *m);
        }
    }

    /// Writes mean and standard deviation (floored at 1e-4; 1 before any data) as f32.
    fn export(&self, mean: &mut [f32], std: &mut [f32]) {
        for k in 0..self.mean.len() {
            mean[k] = self.mean[k] as f32;
            std[k] = if self.count == 0 {
                1.0
            } else {
                ((self.m2[k] / self.count as f64).sqrt()).max(1e-4) as f32
            };
        }
    }
}

/// What a checkpoint's JSON holds besides the network, the optimiser and the buffer.
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
    pos: usize,
    len: usize,
    rng_seed: Vec<u8>,
    rng_stream: u64,
    rng_word_pos: String,
}

/// The dynamics model with its transition buffer, optimiser, normalisation and error tracking.
#[derive(Debug, Clone)]
pub struct DynamicsModel {
    config: DynamicsConfig,
    obs_dim: usize,
    act_dim: usize,
    net: Mlp,
    adam: Adam,
    rng: ChaCha8Rng,
    // Ring buffer of real transitions, row-major.
    buf_obs: Vec<f32>,
    buf_act: Vec<f32>,
    buf_next: Vec<f32>,
    pos: usize,
    len: usize,
    input_stats: Stats,
    delta_stats: Stats,
    // Normalisation as f32, refreshed on every added transition.
    in_mean: Vec<f32>,
    in_std: Vec<f32>,
    d_mean: Vec<f32>,
    d_std: Vec<f32>,
    // Preallocated batch matrices (row-major, batch x width) and a one-sample input.
    batch_in: Vec<f32>,
    batch_target: Vec<f32>,
    batch_grad: Vec<f32>,
    one_in: Vec<f32>,
    error: PredictionError,
    real_steps: u64,
    gradient_steps: u64,
    last_loss: f32,
}

impl DynamicsModel {
    /// A fresh model for observations of `obs_dim` and actions of `act_dim`, its weights drawn from
    /// `rng` (PyTorch's default initialisation) and its own sampling RNG seeded from `rng`. The
    /// buffer is allocated once here (`buffer_size` transitions).
    ///
    /// # Errors
    /// A zero dimension or an invalid configuration.
    pub fn new<R: Rng + ?Sized>(
        obs_dim: usize,
        act_dim: usize,
        config: DynamicsConfig,
        rng: &mut R,
    ) -> Result<Self> {
        config.check()?;
        if obs_dim == 0 || act_dim == 0 {
            return Err(DefenderError::Config(format!(
                "dynamics: obs_dim and act_dim must be >= 1, got {obs_dim} and {act_dim}"
            )));
        }
        let mut widths = vec![obs_dim + act_dim];
        widths.extend_from_slice(&config.hidden);
        widths.push(obs_dim);
        let net = Mlp::try_new(&widths, Activation::Relu, Activation::Identity, rng)?;
        let adam = Adam::new(&net, AdamConfig { lr: config.learning_rate, ..AdamConfig::default() });
        let sampler = ChaCha8Rng::seed_from_u64(rng.random());
        Ok(Self::assemble(config, obs_dim, act_dim, net, adam, sampler))
    }

    fn assemble(
        config: DynamicsConfig,
        obs_dim: usize,
        act_dim: usize,
        net: Mlp,
        adam: Adam,
        rng: ChaCha8Rng,
    ) -> Self {
        let (cap, b, inp) = (config.buffer_size, config.batch_size, obs_dim + act_dim);
        Self {
            obs_dim,
            act_dim,
            net,
            adam,
            rng,
            buf_obs: vec![0.0; cap * obs_dim],
            buf_act: vec![0.0; cap * act_dim],
            buf_next: vec![0.0; cap * obs_dim],
            pos: 0,
            len: 0,
            input_stats: Stats::new(inp),
            delta_stats: Stats::new(obs_dim),
            in_mean: vec![0.0; inp],
            in_std: vec![1.0; inp],
            d_mean: vec![0.0; obs_dim],
            d_std: vec![1.0; obs_dim],
            batch_in: vec![0.0; b * inp],
            batch_target: vec![0.0; b * obs_dim],
            batch_grad: vec![0.0; b * obs_dim],
            one_in: vec![0.0; inp],
            error: PredictionError::default(),
            real_steps: 0,
            gradient_steps: 0,
            last_loss: f32::NAN,
            config,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DynamicsConfig {
        &self.config
    }

    /// Sets the threading of the network's GEMMs (DESIGN: a run is single-threaded by default;
    /// the network starts with `defender-nn`'s default).
    pub fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.net.set_parallelism(parallelism);
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// Real transitions held (at most `buffer_size`).
    pub fn buffer_len(&self) -> usize {
        self.len
    }

    /// Real transitions seen in total.
    pub fn real_steps(&self) -> u64 {
        self.real_steps
    }

    /// Gradient steps taken.
    pub fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    /// The training loss (normalised units) of the last gradient step (NaN before any).
    pub fn last_loss(&self) -> f32 {
        self.last_loss
    }

    /// The prediction error on fresh transitions.
    pub fn prediction_error(&self) -> PredictionError {
        self.error
    }

    fn normalise_input(
        &self,
        obs: impl Iterator<Item = f32>,
        act: impl Iterator<Item = f32>,
        out: &mut [f32],
    ) {
        for (k, v) in obs.chain(act).enumerate() {
            out[k] = (v - self.in_mean[k]) / self.in_std[k];
        }
    }

    /// Predicts the next observation of (`obs`, `action`) into `out` (`obs_dim` values).
    ///
    /// # Errors
    /// Wrong lengths.
    pub fn predict_into(&mut self, obs: &[f64], action: &[f64], out: &mut [f64]) -> Result<()> {
        self.check(obs.len(), action.len())?;
        if out.len() != self.obs_dim {
            return Err(mismatch("prediction output length", self.obs_dim, out.len()));
        }
        let mut one = std::mem::take(&mut self.one_in);
        self.normalise_input(obs.iter().map(|&v| v as f32), action.iter().map(|&v| v as f32), &mut one);
        let y = self.net.forward(MatRef::from_row_major_slice(&one, 1, one.len()));
        for k in 0..self.obs_dim {
            out[k] = obs[k] + f64::from(self.d_mean[k]) + f64::from(self.d_std[k]) * f64::from(y[(0, k)]);
        }
        self.one_in = one;
        Ok(())
    }

    /// Predicts the next observation of (`obs`, `action`).
    ///
    /// # Errors
    /// Wrong lengths.
    pub fn predict(&mut self, obs: &[f64], action: &[f64]) -> Result<Vec<f64>> {
        let mut out = vec![0.0; self.obs_dim];
        self.predict_into(obs, action, &mut out)?;
        Ok(out)
    }

    /// The checks [`DynamicsModel::observe`] makes on a transition, for a model of these
    /// dimensions: lengths, and finite values only.
    ///
    /// # Errors
    /// As [`DynamicsModel::observe`].
    pub(crate) fn check_transition(
        obs_dim: usize,
        act_dim: usize,
        obs: &[f64],
        action: &[f64],
        next_obs: &[f64],
    ) -> Result<()> {
        Self::check_input(obs_dim, act_dim, obs.len(), action.len())?;
        if next_obs.len() != obs_dim {
            return Err(mismatch("next observation length (dynamics model)", obs_dim, next_obs.len()));
        }
        if obs.iter().chain(action).chain(next_obs).any(|v| !v.is_finite()) {
            return Err(DefenderError::Config("dynamics: a transition with NaN or infinite values".into()));
        }
        Ok(())
    }

    fn check(&self, obs: usize, act: usize) -> Result<()> {
        Self::check_input(self.obs_dim, self.act_dim, obs, act)
    }

    /// The lengths of an input (observation, action) against a model's dimensions.
    fn check_input(obs_dim: usize, act_dim: usize, obs: usize, act: usize) -> Result<()> {
        if obs != obs_dim {
            return Err(mismatch("observation length (dynamics model)", obs_dim, obs));
        }
        if act != act_dim {
            return Err(mismatch("action length (dynamics model)", act_dim, act));
        }
        Ok(())
    }

    /// One real transition `(obs, action) -> next_obs`: measures the prediction error on it,
    /// stores it, and trains as configured (by default one gradient step). Non-finite values are
    /// refused (they would poison the network).
    ///
    /// # Errors
    /// Wrong lengths or non-finite values; nothing is stored then.
    pub fn observe(&mut self, obs: &[f64], action: &[f64], next_obs: &[f64]) -> Result<()> {
        Self::check_transition(self.obs_dim, self.act_dim, obs, action, next_obs)?;
        // Held-out error: predict before this transition influences anything.
        let mut se = 0.0f64;
        {
            let mut one = std::mem::take(&mut self.one_in);
            self.normalise_input(obs.iter().map(|&v| v as f32), action.iter().map(|&v| v as f32), &mut one);
            let y = self.net.forward(MatRef::from_row_major_slice(&one, 1, one.len()));
            for k in 0..self.obs_dim {
                let pred =
                    obs[k] + f64::from(self.d_mean[k]) + f64::from(self.d_std[k]) * f64::from(y[(0, k)]);
                se += (pred - next_obs[k]).powi(2);
            }
            self.one_in = one;
        }
        let mse = se / self.obs_dim as f64;
        let e = &mut self.error;
        e.count += 1;
        e.last = mse;
        e.ema = if e.count == 1 { mse } else { e.ema + self.config.error_ema_alpha * (mse - e.ema) };
        e.mean += (mse - e.mean) / e.count as f64;

        // Store.
        let (o, a, p) = (self.obs_dim, self.act_dim, self.pos);
        for k in 0..o {
            self.buf_obs[p * o + k] = obs[k] as f32;
            self.buf_next[p * o + k] = next_obs[k] as f32;
        }
        for (dst, &v) in self.buf_act[p * a..(p + 1) * a].iter_mut().zip(action) {
            *dst = v as f32;
        }
        self.pos = (p + 1) % self.config.buffer_size;
        self.len = (self.len + 1).min(self.config.buffer_size);
        self.input_stats.add(obs.iter().chain(action).copied());
        self.delta_stats.add(obs.iter().zip(next_obs).map(|(s, n)| n - s));
        let inp = o + a;
        self.input_stats.export(&mut self.in_mean, &mut self.in_std);
        self.delta_stats.export(&mut self.d_mean, &mut self.d_std);
        debug_assert_eq!(self.in_mean.len(), inp);
        self.real_steps += 1;

        if self.len >= self.config.learning_starts
            && self.real_steps.is_multiple_of(self.config.train_freq as u64)
        {
            for _ in 0..self.config.gradient_steps {
                self.train_step();
            }
        }
        Ok(())
    }

    /// One gradient step on a batch drawn uniformly (with replacement) from the buffer. Does
    /// nothing on an empty buffer. Allocation-free.
    pub fn train_step(&mut self) {
        if self.len == 0 {
            return;
        }
        let (o, a, b) = (self.obs_dim, self.act_dim, self.config.batch_size);
        let inp = o + a;
        let mut x = std::mem::take(&mut self.batch_in);
        let mut t = std::mem::take(&mut self.batch_target);
        let mut g = std::mem::take(&mut self.batch_grad);
        for r in 0..b {
            let i = self.rng.random_range(0..self.len);
            let (obs, act, next) = (
                &self.buf_obs[i * o..(i + 1) * o],
                &self.buf_act[i * a..(i + 1) * a],
                &self.buf_next[i * o..(i + 1) * o],
            );
            self.normalise_input(obs.iter().copied(), act.iter().copied(), &mut x[r * inp..(r + 1) * inp]);
            for k in 0..o {
                t[r * o + k] = (next[k] - obs[k] - self.d_mean[k]) / self.d_std[k];
            }
        }
        self.net.zero_grad();
        let pred = self.net.forward(MatRef::from_row_major_slice(&x, b, inp));
        let loss = mse_loss_grad(
            pred,
            MatRef::from_row_major_slice(&t, b, o),
            MatMut::from_row_major_slice_mut(&mut g, b, o),
        );
        self.net.backward_params(MatRef::from_row_major_slice(&g, b, o));
        self.adam.step(&mut self.net);
        self.last_loss = loss;
        self.gradient_steps += 1;
        self.batch_in = x;
        self.batch_target = t;
        self.batch_grad = g;
    }

    /// Saves the whole state (network, optimiser, buffer, normalisation, RNG, counters) into
    /// directory `dir` (created if needed) as `dynamics.safetensors`, `dynamics_adam.safetensors`,
    /// `dynamics_buffer.npz` and `dynamics_state.json`, each written atomically.
    ///
    /// # Errors
    /// An I/O error.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<()> {
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|e| DefenderError::io(dir, e))?;
        let net = dir.join("dynamics.safetensors");
        commit_file(&net, |tmp| Ok(self.net.save_safetensors(tmp)?))?;
        let adam = dir.join("dynamics_adam.safetensors");
        commit_file(&adam, |tmp| Ok(self.adam.save_safetensors(tmp)?))?;
        let buffer = dir.join("dynamics_buffer.npz");
        let (o, a, n) = (self.obs_dim, self.act_dim, self.len);
        write_atomic(&buffer, |w| {
            let mut npz = NpzWriter::new(w, &buffer);
            npz.write("obs", &[n, o], &self.buf_obs[..n * o])?;
            npz.write("act", &[n, a], &self.buf_act[..n * a])?;
            npz.write("next_obs", &[n, o], &self.buf_next[..n * o])?;
            npz.finish()?;
            Ok(())
        })?;
        let state = SavedState {
            config: self.config.clone(),
            obs_dim: o,
            act_dim: a,
            input_stats: self.input_stats.clone(),
            delta_stats: self.delta_stats.clone(),
            error: self.error,
            real_steps: self.real_steps,
            gradient_steps: self.gradient_steps,
            last_loss: self.last_loss,
            pos: self.pos,
            len: self.len,
            rng_seed: self.rng.get_seed().to_vec(),
            rng_stream: self.rng.get_stream(),
            rng_word_pos: self.rng.get_word_pos().to_string(),
        };
        let json = dir.join("dynamics_state.json");
        write_atomic(&json, |w| {
            serde_json::to_writer_pretty(&mut *w, &state)
                .map_err(|e| DefenderError::Checkpoint { path: json.clone(), what: e.to_string() })
        })
    }

    /// Restores a model saved by [`DynamicsModel::save`]; it continues bit for bit as the saved
    /// one would have.
    ///
    /// # Errors
    /// Missing or inconsistent files, naming the file.
    pub fn load(dir: impl AsRef<Path>) -> Result<Self> {
        let dir = dir.as_ref();
        let json = dir.join("dynamics_state.json");
        let text = std::fs::read_to_string(&json).map_err(|e| DefenderError::io(&json, e))?;
        let bad = |what: String| DefenderError::Checkpoint { path: json.clone(), what };
        let s: SavedState = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        s.config.check()?;
        let net = Mlp::load_safetensors(dir.join("dynamics.safetensors"))?;
        let mut widths = vec![s.obs_dim + s.act_dim];
        widths.extend_from_slice(&s.config.hidden);
        widths.push(s.obs_dim);
        if net.widths() != widths.as_slice() {
            return Err(bad(format!(
                "network widths {:?} do not match the saved config {widths:?}",
                net.widths()
            )));
        }
        let adam = Adam::load_safetensors(dir.join("dynamics_adam.safetensors"), &net)?;
        let seed: [u8; 32] =
            s.rng_seed.as_slice().try_into().map_err(|_| bad("rng_seed must be 32 bytes".into()))?;
        let mut rng = ChaCha8Rng::from_seed(seed);
        rng.set_stream(s.rng_stream);
        rng.set_word_pos(s.rng_word_pos.parse().map_err(|e| bad(format!("rng_word_pos: {e}")))?);
        let mut m = Self::assemble(s.config, s.obs_dim, s.act_dim, net, adam, rng);
        let buffer = dir.join("dynamics_buffer.npz");
        let mut npz = NpzReader::open(&buffer)?;
        for (name, dst, width) in [
            ("obs", &mut m.buf_obs, s.obs_dim),
            ("act", &mut m.buf_act, s.act_dim),
            ("next_obs", &mut m.buf_next, s.obs_dim),
        ] {
            let arr = npz
                .read(name)?
                .ok_or_else(|| bad(format!("{}: array '{name}' missing", buffer.display())))?;
            match arr.values {
                Values::F32(v) if arr.shape == [s.len, width] && v.len() <= dst.len() => {
                    dst[..v.len()].copy_from_slice(&v)
                }
                _ => {
                    return Err(bad(format!(
                        "{}: array '{name}' is not float32 [{}, {width}]",
                        buffer.display(),
                        s.len
                    )));
                }
            }
        }
        m.pos = s.pos;
        m.len = s.len;
        m.input_stats = s.input_stats;
        m.delta_stats = s.delta_stats;
        m.input_stats.export(&mut m.in_mean, &mut m.in_std);
        m.delta_stats.export(&mut m.d_mean, &mut m.d_std);
        m.error = s.error;
        m.real_steps = s.real_steps;
        m.gradient_steps = s.gradient_steps;
        m.last_loss = s.last_loss;
        Ok(m)
    }
}

fn mismatch(what: &str, expected: usize, got: usize) -> DefenderError {
    DefenderError::Mismatch { what: what.into(), expected: expected.to_string(), got: got.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear system s' = A s + B a with a known answer.
    fn step(s: &[f64], a: &[f64]) -> Vec<f64> {
        vec![0.9 * s[0] + 0.1 * s[1] + 0.5 * a[0], -0.2 * s[0] + 0.95 * s[1] + 0.3 * a[0], s[2] + 0.05]
    }

    fn small_config() -> DynamicsConfig {
        DynamicsConfig {
            hidden: vec![64, 64],
            batch_size: 64,
            buffer_size: 5000,
            learning_rate: 1e-3,
            ..Default::default()
        }
    }

    #[test]
    fn learns_a_linear_system_and_tracks_its_error() {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
        let mut s = vec![0.5, -0.5, 0.0];
        let mut first = None;
        for t in 0..3000 {
            let a = [rng.random_range(-1.0..1.0)];
            let n = step(&s, &a);
            m.observe(&s, &a, &n).unwrap();
            if t == 99 {
                first = Some(m.prediction_error().mean);
            }
            s = if t % 50 == 49 {
                vec![rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0]
            } else {
                n
            };
        }
        let err = m.prediction_error();
        assert_eq!(err.count, 3000);
        assert_eq!(m.gradient_steps(), 3000, "one gradient step per real step");
        let first = first.unwrap();
        assert!(err.ema < first / 10.0, "the error falls: first 100 mean {first}, now ema {}", err.ema);
        let s = [0.2, 0.1, 1.0];
        let p = m.predict(&s, &[0.5]).unwrap();
        let truth = step(&s, &[0.5]);
        for k in 0..3 {
            assert!((p[k] - truth[k]).abs() < 0.05, "{p:?} vs {truth:?}");
        }
    }

    #[test]
    fn train_freq_and_gradient_steps_are_honoured() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let cfg = DynamicsConfig { train_freq: 4, gradient_steps: 2, learning_starts: 8, ..small_config() };
        let mut m = DynamicsModel::new(3, 1, cfg, &mut rng).unwrap();
        for t in 0..20 {
            let s = [t as f64, 0.0, 0.0];
            m.observe(&s, &[0.0], &step(&s, &[0.0])).unwrap();
        }
        // Rounds at real steps 8, 12, 16, 20 (buffer >= 8): 4 rounds x 2 steps.
        assert_eq!(m.gradient_steps(), 8);
        assert!(m.last_loss().is_finite());
    }

    #[test]
    fn bad_transitions_are_refused() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
        assert!(m.observe(&[0.0; 2], &[0.0], &[0.0; 3]).is_err());
        assert!(m.observe(&[0.0; 3], &[0.0; 2], &[0.0; 3]).is_err());
        assert!(m.observe(&[0.0; 3], &[f64::NAN], &[0.0; 3]).is_err());
        assert_eq!(m.buffer_len(), 0);
        assert!(
            DynamicsModel::new(3, 1, DynamicsConfig { batch_size: 0, ..small_config() }, &mut rng).is_err()
        );
    }

    #[test]
    fn save_and_load_continue_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut m = DynamicsModel::new(3, 1, small_config(), &mut rng).unwrap();
        let mut s = vec![0.1, 0.2, 0.0];
        for _ in 0..100 {
            let a = [rng.random_range(-1.0..1.0)];
            let n = step(&s, &a);
            m.observe(&s, &a, &n).unwrap();
            s = n;
        }
        let dir = tempfile::tempdir().unwrap();
        m.save(dir.path()).unwrap();
        let mut back = DynamicsModel::load(dir.path()).unwrap();
        for _ in 0..50 {
            let a = [rng.random_range(-1.0..1.0)];
            let n = step(&s, &a);
            m.observe(&s, &a, &n).unwrap();
            back.observe(&s, &a, &n).unwrap();
            s = n;
        }
        assert_eq!(m.predict(&s, &[0.3]).unwrap(), back.predict(&s, &[0.3]).unwrap());
        assert_eq!(m.prediction_error(), back.prediction_error());
        assert_eq!(m.gradient_steps(), back.gradient_steps());
        std::fs::remove_file(dir.path().join("dynamics_buffer.npz")).unwrap();
        assert!(DynamicsModel::load(dir.path()).unwrap_err().to_string().contains("dynamics_buffer.npz"));
    }
}
