//! The `classifier` trigger (crate::trigger; docs/SPEC.md section 15): a small network that reads
//! the last `window` trajectory elements and gives the probability that a failure is at most
//! `horizon` steps ahead; the episode ends when it passes `threshold`.
//!
//! It learns from exactly what the DTW filter reads: the demonstrations (each step of an unsafe
//! one labelled unsafe when its failure is at most `horizon` steps ahead, every other step safe)
//! and, with `[defender.filter.own_episodes]`, the agent's own finished episodes as the DTW
//! filter takes them (a crash like an unsafe demonstration, one that reached the horizon safe, a
//! filtered one not at all; at most `keep` per group, the oldest replaced), with `update_steps`
//! gradient steps after each joins. Elements are z-scored by the demonstrations' statistics.
//! Batches are half unsafe, half safe (the unsafe steps are a few percent of all), so the
//! probability is one under equal priors: the threshold is the screened setting.

use std::collections::VecDeque;
use std::path::Path;

use defender_nn::faer::MatRef;
use defender_nn::{Activation, Adam, AdamConfig, Mlp};
use defender_rl::Outcome;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::atomic::commit_file;
use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};
use crate::strategy::Mode;
use crate::trigger::ClassifierOptions;

const HIDDEN: usize = 64;
const BATCH: usize = 256;
const LEARNING_RATE: f32 = 1e-3;
const DIR: &str = "classifier";
const NET_FILE: &str = "net.safetensors";
const ADAM_FILE: &str = "adam.safetensors";
const STATE_FILE: &str = "state.json";

/// One episode's normalised elements and per-step labels (1: a failure at most `horizon` ahead).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct Labelled {
    elements: Vec<f32>,
    labels: Vec<f32>,
}

/// What a checkpoint keeps besides the network and the optimiser.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Saved {
    options: ClassifierOptions,
    element_dim: usize,
    rng: ChaCha8Rng,
    own: [VecDeque<Labelled>; 2],
    gradient_steps: u64,
}

/// The classifier and its training data.
#[derive(Debug, Clone)]
pub struct Classifier {
    options: ClassifierOptions,
    mode: Mode,
    element_dim: usize,
    mean: Vec<f32>,
    inv_std: Vec<f32>,
    net: Mlp,
    adam: Adam,
    rng: ChaCha8Rng,
    demos: Vec<Labelled>,
    own: [VecDeque<Labelled>; 2],
    keep: Option<usize>,
    /// `(set, episode, step)` of every unsafe and every safe step, rebuilt when the data change.
    index: [Vec<(u8, u32, u32)>; 2],
    episode: Vec<f32>,
    feature: Vec<f32>,
    batch_x: Vec<f32>,
    batch_y: Vec<f32>,
    batch_grad: Vec<f32>,
    gradient_steps: u64,
    last_probability: f64,
}

fn sigmoid(z: f32) -> f32 {
    1.0 / (1.0 + (-z).exp())
}

impl Classifier {
    /// A classifier of `demos` (both groups) in `mode`, trained for `pretrain_steps` before it
    /// returns; its weights and batches drawn from `rng`. `keep`: own episodes per group.
    ///
    /// # Errors
    /// Invalid options, or demonstrations without an unsafe step to learn from.
    pub fn new<R: Rng + ?Sized>(
        demos: &EpisodeSet,
        mode: Mode,
        options: ClassifierOptions,
        keep: Option<usize>,
        rng: &mut R,
    ) -> Result<Self> {
        options.validate().map_err(DefenderError::Config)?;
        let (o, a) = (demos.obs_dim(), demos.act_dim());
        let element_dim = if mode == Mode::StateAction { o + a } else { o };
        let mut raw = Vec::new();
        for ep in demos.episodes() {
            let steps = ep.rew.len();
            let mut elements = Vec::with_capacity(steps * element_dim);
            for t in 0..steps {
                elements.extend_from_slice(&ep.obs[t * o..(t + 1) * o]);
                if mode == Mode::StateAction {
                    elements.extend_from_slice(&ep.act[t * a..(t + 1) * a]);
                }
            }
            let labels = failure_labels(steps, ep.crashed, options.horizon);
            raw.push(Labelled { elements, labels });
        }
        let (mean, inv_std) = column_stats(&raw, element_dim);
        for ep in &mut raw {
            normalise(&mut ep.elements, &mean, &inv_std);
        }
        let inputs = options.window * element_dim;
        let net = Mlp::try_new(&[inputs, HIDDEN, HIDDEN, 1], Activation::Relu, Activation::Identity, rng)?;
        let adam = Adam::new(&net, AdamConfig { lr: LEARNING_RATE, ..AdamConfig::default() });
        let mut classifier = Self {
            options,
            mode,
            element_dim,
            mean,
            inv_std,
            net,
            adam,
            rng: ChaCha8Rng::seed_from_u64(rng.random()),
            demos: raw,
            own: [VecDeque::new(), VecDeque::new()],
            keep,
            index: [Vec::new(), Vec::new()],
            episode: Vec::new(),
            feature: vec![0.0; inputs],
            batch_x: vec![0.0; BATCH * inputs],
            batch_y: vec![0.0; BATCH],
            batch_grad: vec![0.0; BATCH],
            gradient_steps: 0,
            last_probability: 0.0,
        };
        classifier.reindex();
        if classifier.index[1].is_empty() {
            return Err(DefenderError::Config(
                "the classifier trigger needs an unsafe demonstration to learn from; the set has none".into(),
            ));
        }
        classifier.train(options.pretrain_steps);
        Ok(classifier)
    }

    /// The options.
    pub fn options(&self) -> ClassifierOptions {
        self.options
    }

    /// The probability of the last [`Classifier::push`].
    pub fn last_probability(&self) -> f64 {
        self.last_probability
    }

    /// Gradient steps so far (the pretraining's included).
    pub fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    /// Own episodes kept per group `(safe, unsafe)`.
    pub fn own_counts(&self) -> (usize, usize) {
        (self.own[0].len(), self.own[1].len())
    }

    /// Starts an episode.
    pub fn begin(&mut self) {
        self.episode.clear();
    }

    /// Appends step `t`'s element and returns the probability that a failure is at most
    /// `horizon` steps ahead.
    ///
    /// # Errors
    /// Vectors of the wrong length or non-finite values.
    pub fn push(&mut self, obs: &[f64], action: &[f64]) -> Result<f64> {
        let d = self.element_dim;
        let start = self.episode.len();
        self.episode.extend(obs.iter().map(|&v| v as f32));
        if self.mode == Mode::StateAction {
            self.episode.extend(action.iter().map(|&v| v as f32));
        }
        if self.episode.len() - start != d || self.episode[start..].iter().any(|v| !v.is_finite()) {
            self.episode.truncate(start);
            return Err(DefenderError::Config(format!(
                "classifier trigger: an element of {} finite values was expected",
                d
            )));
        }
        normalise(&mut self.episode[start..], &self.mean, &self.inv_std);
        let t = self.episode.len() / d - 1;
        window_into(&self.episode, d, t, self.options.window, &mut self.feature);
        let out = self.net.forward(MatRef::from_row_major_slice(&self.feature, 1, self.feature.len()));
        self.last_probability = f64::from(sigmoid(*out.get(0, 0)));
        Ok(self.last_probability)
    }

    /// Ends the episode: with own episodes on, a crash joins the unsafe data and an episode that
    /// reached the horizon the safe data, then `update_steps` gradient steps; a filtered one is
    /// dropped (what follows it never happened).
    pub fn end(&mut self, outcome: Outcome) {
        let Some(keep) = self.keep else { return };
        let group = match outcome {
            Outcome::Crashed => 1,
            Outcome::Truncated => 0,
            Outcome::Filtered => return,
        };
        let steps = self.episode.len() / self.element_dim;
        if steps == 0 {
            return;
        }
        let labels = failure_labels(steps, group == 1, self.options.horizon);
        let own = &mut self.own[group];
        if own.len() == keep {
            own.pop_front();
        }
        own.push_back(Labelled { elements: std::mem::take(&mut self.episode), labels });
        self.reindex();
        self.train(self.options.update_steps);
    }

    fn reindex(&mut self) {
        let mut index = [Vec::new(), Vec::new()];
        let sets = std::iter::once((0u8, self.demos.iter().collect::<Vec<_>>()))
            .chain((0..2).map(|g| (g as u8 + 1, self.own[g].iter().collect())));
        for (which, episodes) in sets {
            for (e, ep) in episodes.iter().enumerate() {
                for (t, &y) in ep.labels.iter().enumerate() {
                    index[usize::from(y > 0.5)].push((which, e as u32, t as u32));
                }
            }
        }
        self.index = index;
    }

    /// `steps` gradient steps of the binary cross-entropy on batches half unsafe, half safe.
    fn train(&mut self, steps: usize) {
        let (inputs, d, w) = (self.feature.len(), self.element_dim, self.options.window);
        if self.index[0].is_empty() || self.index[1].is_empty() {
            return;
        }
        for _ in 0..steps {
            for r in 0..BATCH {
                let class = usize::from(r % 2 == 1);
                let pick = self.index[class][self.rng.random_range(0..self.index[class].len())];
                let ep = match pick.0 {
                    0 => &self.demos[pick.1 as usize],
                    g => &self.own[usize::from(g - 1)][pick.1 as usize],
                };
                window_into(
                    &ep.elements,
                    d,
                    pick.2 as usize,
                    w,
                    &mut self.batch_x[r * inputs..(r + 1) * inputs],
                );
                self.batch_y[r] = class as f32;
            }
            self.net.zero_grad();
            let out = self.net.forward(MatRef::from_row_major_slice(&self.batch_x, BATCH, inputs));
            for r in 0..BATCH {
                self.batch_grad[r] = (sigmoid(*out.get(r, 0)) - self.batch_y[r]) / BATCH as f32;
            }
            self.net.backward_params(MatRef::from_row_major_slice(&self.batch_grad, BATCH, 1));
            self.adam.step(&mut self.net);
            self.gradient_steps += 1;
        }
    }

    /// Writes the network, the optimiser and the data that changes into `dir/classifier/`.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let dir = dir.join(DIR);
        std::fs::create_dir_all(&dir).map_err(|e| DefenderError::io(&dir, e))?;
        commit_file(&dir.join(NET_FILE), |tmp| Ok(self.net.save_safetensors(tmp)?))?;
        commit_file(&dir.join(ADAM_FILE), |tmp| Ok(self.adam.save_safetensors(tmp)?))?;
        let saved = Saved {
            options: self.options,
            element_dim: self.element_dim,
            rng: self.rng.clone(),
            own: self.own.clone(),
            gradient_steps: self.gradient_steps,
        };
        let path = dir.join(STATE_FILE);
        commit_file(&path, |tmp| {
            let text = serde_json::to_vec(&saved)
                .map_err(|e| DefenderError::Checkpoint { path: path.clone(), what: e.to_string() })?;
            std::fs::write(tmp, text).map_err(|e| DefenderError::io(tmp, e))
        })
    }

    /// Restores what [`Classifier::save`] wrote.
    ///
    /// # Errors
    /// A missing file, or one saved by a classifier of other settings.
    pub fn load(&mut self, dir: &Path) -> Result<()> {
        let dir = dir.join(DIR);
        let path = dir.join(STATE_FILE);
        let text = std::fs::read(&path).map_err(|e| DefenderError::io(&path, e))?;
        let bad = |what: String| DefenderError::Checkpoint { path: path.clone(), what };
        let saved: Saved = serde_json::from_slice(&text).map_err(|e| bad(e.to_string()))?;
        if saved.options != self.options || saved.element_dim != self.element_dim {
            return Err(bad(format!(
                "saved by a classifier with {:?} over {} columns; this run has {:?} over {}",
                saved.options, saved.element_dim, self.options, self.element_dim
            )));
        }
        let net = Mlp::load_safetensors(dir.join(NET_FILE))?;
        if net.widths() != self.net.widths() {
            return Err(bad(format!("network widths {:?}, expected {:?}", net.widths(), self.net.widths())));
        }
        self.adam = Adam::load_safetensors(dir.join(ADAM_FILE), &net)?;
        self.net = net;
        self.rng = saved.rng;
        self.own = saved.own;
        self.gradient_steps = saved.gradient_steps;
        self.reindex();
        Ok(())
    }
}

/// Per step of an episode of `steps` decisions: 1 where a failure is at most `horizon` steps
/// ahead (a crashed episode fails on its last step, which is 1 ahead), else 0.
fn failure_labels(steps: usize, crashed: bool, horizon: usize) -> Vec<f32> {
    (0..steps).map(|t| if crashed && steps - t <= horizon { 1.0 } else { 0.0 }).collect()
}

/// Each column's mean and `1 / std` over every element of `episodes` (`1` where a column is
/// constant).
fn column_stats(episodes: &[Labelled], d: usize) -> (Vec<f32>, Vec<f32>) {
    let (mut sum, mut sq, mut n) = (vec![0.0f64; d], vec![0.0f64; d], 0usize);
    for ep in episodes {
        for row in ep.elements.chunks_exact(d) {
            for (j, &v) in row.iter().enumerate() {
                sum[j] += f64::from(v);
                sq[j] += f64::from(v) * f64::from(v);
            }
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let mean: Vec<f64> = sum.iter().map(|s| s / n).collect();
    let inv_std = sq
        .iter()
        .zip(&mean)
        .map(|(q, m)| {
            let var = (q / n - m * m).max(0.0);
            if var > 1e-12 { (1.0 / var.sqrt()) as f32 } else { 1.0 }
        })
        .collect();
    (mean.into_iter().map(|m| m as f32).collect(), inv_std)
}

fn normalise(elements: &mut [f32], mean: &[f32], inv_std: &[f32]) {
    for row in elements.chunks_exact_mut(mean.len()) {
        for ((v, m), s) in row.iter_mut().zip(mean).zip(inv_std) {
            *v = (*v - m) * s;
        }
    }
}

/// The window ending at step `t` of `elements` (rows of `d`), oldest first, the first row
/// repeated where the episode is shorter than `w`.
fn window_into(elements: &[f32], d: usize, t: usize, w: usize, out: &mut [f32]) {
    for k in 0..w {
        let step = (t + k + 1).saturating_sub(w);
        out[k * d..(k + 1) * d].copy_from_slice(&elements[step * d..(step + 1) * d]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_mark_the_last_horizon_steps_of_a_crash_only() {
        assert_eq!(failure_labels(5, true, 2), vec![0.0, 0.0, 0.0, 1.0, 1.0]);
        assert_eq!(failure_labels(5, false, 2), vec![0.0; 5]);
        assert_eq!(failure_labels(2, true, 9), vec![1.0, 1.0]);
    }

    #[test]
    fn the_window_repeats_the_first_element_before_the_episode_is_long_enough() {
        let elements = [1.0, 10.0, 2.0, 20.0, 3.0, 30.0];
        let mut out = [0.0; 6];
        window_into(&elements, 2, 0, 3, &mut out);
        assert_eq!(out, [1.0, 10.0, 1.0, 10.0, 1.0, 10.0]);
        window_into(&elements, 2, 2, 3, &mut out);
        assert_eq!(out, [1.0, 10.0, 2.0, 20.0, 3.0, 30.0]);
        window_into(&elements, 2, 2, 2, &mut out[..4]);
        assert_eq!(out[..4], [2.0, 20.0, 3.0, 30.0]);
    }
}
