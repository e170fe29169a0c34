//! The dynamics model of SPEC section 5: an MLP `obs+act -> 256 -> 256 -> obs` (ReLU) that
//! supplies the next observation of a filtered step.
//!
//! What it learns: the change `s' - s` from normalised inputs, with an L2 (mean squared error)
//! loss (`normaliser.rs`; SPEC section 5 allows it); the prediction is `s + mu_d + sd_d * net(...)`.
//!
//! How it learns: Adam (lr 3e-4) on batches drawn uniformly with replacement, with the model's
//! own RNG, from its store of real transitions only (never its own predictions; `defender-rl`'s
//! replay buffer); `train_freq`, `gradient_steps` and `batch_size` set the schedule
//! (docs/decisions.md). Before training on a fresh transition it predicts it, and the error of
//! that prediction (MSE over the observation's components, in raw units) is tracked: an honest
//! held-out error. Checkpoints: `checkpoint.rs`.

use defender_nn::faer::{MatMut, MatRef};
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism, mse_loss_grad};
use defender_rl::{Batch, ReplayBuffer, Transition};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{DefenderError, Result};

mod checkpoint;
mod normaliser;
#[cfg(test)]
mod tests;

use normaliser::Normaliser;

/// Hyperparameters of the dynamics model (SPEC section 5's, but for the schedule: see
/// [`DynamicsConfig::default`]).
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
    /// here (one run, one thread; `defender train` turns it on when its networks have two or more
    /// threads). The model alone ignores it.
    pub background: bool,
}

impl Default for DynamicsConfig {
    /// SPEC section 5's model with a cheaper schedule than its default: one gradient step of
    /// batch 64 every 2 real steps at lr 1e-3, about an eighth of the compute of one step of
    /// batch 256 per real step at lr 3e-4 ([`DynamicsConfig::spec_schedule`]) for a held-out
    /// error within 10% of it (measured: docs/decisions.md, docs/benchmarks.md).
    fn default() -> Self {
        Self {
            hidden: vec![256, 256],
            learning_rate: 1e-3,
            batch_size: 64,
            buffer_size: 1_000_000,
            learning_starts: 1,
            train_freq: 2,
            gradient_steps: 1,
            error_ema_alpha: 0.01,
            background: false,
        }
    }
}

impl DynamicsConfig {
    /// SPEC section 5's schedule: one gradient step of batch 256 per real step, Adam lr 3e-4
    /// (the default until the cheaper one was measured to predict nearly as well).
    pub fn spec_schedule() -> Self {
        Self { learning_rate: 3e-4, batch_size: 256, train_freq: 1, gradient_steps: 1, ..Self::default() }
    }

    /// Checks every value's range: the one check of `[defender.dynamics]`, made by
    /// [`DynamicsModel::new`] and by a run's configuration when it is read.
    ///
    /// # Errors
    /// [`DefenderError::Config`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(DefenderError::Config(format!("dynamics: {what}")));
        if self.hidden.contains(&0) {
            return bad("hidden widths must be >= 1");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return bad(&format!("learning_rate = {}: it must be a finite number > 0", self.learning_rate));
        }
        if self.batch_size == 0 || self.buffer_size == 0 || self.train_freq == 0 {
            return bad(&format!(
                "batch_size = {}, buffer_size = {}, train_freq = {}: each must be >= 1",
                self.batch_size, self.buffer_size, self.train_freq
            ));
        }
        // The sizes a network and its batch are built with: refused here, not by an allocation
        // that aborts the process when the model is made.
        let sized = defender_rl::check_layers("hidden", &self.hidden)
            .and_then(|()| defender_rl::check_batch_size(self.batch_size));
        if let Err(e) = sized {
            return bad(&e.to_string().replace("invalid configuration: ", ""));
        }
        if !(0.0..=1.0).contains(&self.error_ema_alpha) || self.error_ema_alpha == 0.0 {
            return bad(&format!("error_ema_alpha = {}: it must be in (0, 1]", self.error_ema_alpha));
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

/// The dynamics model: its network and optimiser, its store of real transitions (`defender-rl`'s
/// replay buffer, sampled with the model's own RNG), its normalisation and its error tracking.
#[derive(Debug, Clone)]
pub struct DynamicsModel {
    config: DynamicsConfig,
    obs_dim: usize,
    act_dim: usize,
    net: Mlp,
    adam: Adam,
    rng: ChaCha8Rng,
    store: ReplayBuffer,
    normaliser: Normaliser,
    // Preallocated: a sampled batch, the network's batch input, target and gradient (row-major,
    // batch x width), a one-sample input, and an action in f32 for the store.
    batch: Batch,
    batch_in: Vec<f32>,
    batch_target: Vec<f32>,
    batch_grad: Vec<f32>,
    one_in: Vec<f32>,
    action_f32: Vec<f32>,
    error: PredictionError,
    real_steps: u64,
    gradient_steps: u64,
    last_loss: f32,
}

/// The network's layer widths: `obs+act -> hidden... -> obs`.
fn widths(obs_dim: usize, act_dim: usize, config: &DynamicsConfig) -> Vec<usize> {
    let mut widths = vec![obs_dim + act_dim];
    widths.extend_from_slice(&config.hidden);
    widths.push(obs_dim);
    widths
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
        config.validate()?;
        if obs_dim == 0 || act_dim == 0 {
            return Err(DefenderError::Config(format!(
                "dynamics: obs_dim and act_dim must be >= 1, got {obs_dim} and {act_dim}"
            )));
        }
        let net =
            Mlp::try_new(&widths(obs_dim, act_dim, &config), Activation::Relu, Activation::Identity, rng)?;
        let adam = Adam::new(&net, AdamConfig { lr: config.learning_rate, ..AdamConfig::default() });
        let sampler = ChaCha8Rng::seed_from_u64(rng.random());
        Self::assemble(config, obs_dim, act_dim, net, adam, sampler)
    }

    /// A model around `net`, `adam` and `rng` with an empty store and no statistics.
    fn assemble(
        config: DynamicsConfig,
        obs_dim: usize,
        act_dim: usize,
        net: Mlp,
        adam: Adam,
        rng: ChaCha8Rng,
    ) -> Result<Self> {
        let store = ReplayBuffer::new(config.buffer_size, obs_dim, act_dim)
            .map_err(|e| DefenderError::Config(format!("dynamics: {e}")))?;
        let (b, inp) = (config.batch_size, obs_dim + act_dim);
        Ok(Self {
            obs_dim,
            act_dim,
            net,
            adam,
            rng,
            store,
            normaliser: Normaliser::new(obs_dim, act_dim),
            batch: Batch::new(b, obs_dim, act_dim),
            batch_in: vec![0.0; b * inp],
            batch_target: vec![0.0; b * obs_dim],
            batch_grad: vec![0.0; b * obs_dim],
            one_in: vec![0.0; inp],
            action_f32: vec![0.0; act_dim],
            error: PredictionError::default(),
            real_steps: 0,
            gradient_steps: 0,
            last_loss: f32::NAN,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DynamicsConfig {
        &self.config
    }

    /// Sets the threading of the network's GEMMs (docs/architecture.md, "One run, one core";
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
        self.store.len()
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

    /// Predicts the next observation of (`obs`, `action`) into `out` (`obs_dim` values).
    ///
    /// # Errors
    /// Wrong lengths.
    pub fn predict_into(&mut self, obs: &[f64], action: &[f64], out: &mut [f64]) -> Result<()> {
        self.check(obs.len(), action.len())?;
        if out.len() != self.obs_dim {
            return Err(mismatch("prediction output length", self.obs_dim, out.len()));
        }
        let (net, norm, one) = (&mut self.net, &self.normaliser, &mut self.one_in);
        norm.input(obs.iter().map(|&v| v as f32), action.iter().map(|&v| v as f32), one);
        let y = net.forward(MatRef::from_row_major_slice(one, 1, one.len()));
        for k in 0..out.len() {
            out[k] = norm.prediction(obs[k], k, y[(0, k)]);
        }
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
            let (net, norm, one) = (&mut self.net, &self.normaliser, &mut self.one_in);
            norm.input(obs.iter().map(|&v| v as f32), action.iter().map(|&v| v as f32), one);
            let y = net.forward(MatRef::from_row_major_slice(one, 1, one.len()));
            for k in 0..self.obs_dim {
                se += (norm.prediction(obs[k], k, y[(0, k)]) - next_obs[k]).powi(2);
            }
        }
        let mse = se / self.obs_dim as f64;
        let e = &mut self.error;
        e.count += 1;
        e.last = mse;
        e.ema = if e.count == 1 { mse } else { e.ema + self.config.error_ema_alpha * (mse - e.ema) };
        e.mean += (mse - e.mean) / e.count as f64;

        for (dst, &v) in self.action_f32.iter_mut().zip(action) {
            *dst = v as f32;
        }
        let t = Transition {
            obs,
            action: &self.action_f32,
            reward: 0.0,
            cost: 0.0,
            next_obs,
            terminated: false,
            truncated: false,
        };
        self.store.push(&t).map_err(|e| DefenderError::Config(format!("dynamics: {e}")))?;
        self.normaliser.add(obs, action, next_obs);
        self.real_steps += 1;

        if self.store.len() >= self.config.learning_starts
            && self.real_steps.is_multiple_of(self.config.train_freq as u64)
        {
            for _ in 0..self.config.gradient_steps {
                self.train_step();
            }
        }
        Ok(())
    }

    /// One gradient step on a batch drawn uniformly (with replacement) from the store with the
    /// model's own RNG. Does nothing on an empty store. Allocation-free.
    pub fn train_step(&mut self) {
        if self.store.sample_into(&mut self.rng, &mut self.batch).is_err() {
            return; // empty: nothing to learn from yet
        }
        let (o, a, b) = (self.obs_dim, self.act_dim, self.config.batch_size);
        let inp = o + a;
        let (batch, norm) = (&self.batch, &self.normaliser);
        for r in 0..b {
            let (obs, next) = (&batch.obs[r * o..(r + 1) * o], &batch.next_obs[r * o..(r + 1) * o]);
            let act = &batch.actions[r * a..(r + 1) * a];
            norm.input(obs.iter().copied(), act.iter().copied(), &mut self.batch_in[r * inp..(r + 1) * inp]);
            norm.target(obs, next, &mut self.batch_target[r * o..(r + 1) * o]);
        }
        self.net.zero_grad();
        let pred = self.net.forward(MatRef::from_row_major_slice(&self.batch_in, b, inp));
        let loss = mse_loss_grad(
            pred,
            MatRef::from_row_major_slice(&self.batch_target, b, o),
            MatMut::from_row_major_slice_mut(&mut self.batch_grad, b, o),
        );
        self.net.backward_params(MatRef::from_row_major_slice(&self.batch_grad, b, o));
        self.adam.step(&mut self.net);
        self.last_loss = loss;
        self.gradient_steps += 1;
    }
}

fn mismatch(what: &str, expected: usize, got: usize) -> DefenderError {
    DefenderError::Mismatch { what: what.into(), expected: expected.to_string(), got: got.to_string() }
}
