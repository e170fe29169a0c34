//! The dynamics model's normalisation: the network sees `[(s - mu_s) / sd_s, (a - mu_a) / sd_a]`
//! and learns the change `(s' - s - mu_d) / sd_d`, so one learning rate fits observations of
//! very different scales (SPEC section 5 allows it). The statistics are running means and
//! standard deviations (Welford, f64) of every real transition added, floored at 1e-4, and kept
//! as f32 for the network's arithmetic.

use serde::{Deserialize, Serialize};

/// Running mean and variance per component (Welford).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Stats {
    count: u64,
    mean: Vec<f64>,
    m2: Vec<f64>,
}

impl Stats {
    fn new(dim: usize) -> Self {
        Self { count: 0, mean: vec![0.0; dim], m2: vec![0.0; dim] }
    }

    fn dim(&self) -> usize {
        self.mean.len()
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

/// The input and output normalisation of a model of `obs_dim` observations and `act_dim` actions.
#[derive(Debug, Clone)]
pub(super) struct Normaliser {
    input: Stats,
    delta: Stats,
    in_mean: Vec<f32>,
    in_std: Vec<f32>,
    d_mean: Vec<f32>,
    d_std: Vec<f32>,
}

impl Normaliser {
    /// Before any data: mean 0, standard deviation 1.
    pub(super) fn new(obs_dim: usize, act_dim: usize) -> Self {
        Self::from_stats(Stats::new(obs_dim + act_dim), Stats::new(obs_dim))
    }

    /// From saved statistics (`input`: observation then action; `delta`: `s' - s`).
    pub(super) fn from_stats(input: Stats, delta: Stats) -> Self {
        let (inp, obs) = (input.dim(), delta.dim());
        let mut n = Self {
            input,
            delta,
            in_mean: vec![0.0; inp],
            in_std: vec![1.0; inp],
            d_mean: vec![0.0; obs],
            d_std: vec![1.0; obs],
        };
        n.input.export(&mut n.in_mean, &mut n.in_std);
        n.delta.export(&mut n.d_mean, &mut n.d_std);
        n
    }

    /// The saved statistics (`input`, `delta`).
    pub(super) fn stats(&self) -> (&Stats, &Stats) {
        (&self.input, &self.delta)
    }

    /// Dimensions the statistics were made for: (`obs_dim + act_dim`, `obs_dim`).
    pub(super) fn dims(&self) -> (usize, usize) {
        (self.input.dim(), self.delta.dim())
    }

    /// Adds one real transition to the statistics.
    pub(super) fn add(&mut self, obs: &[f64], action: &[f64], next_obs: &[f64]) {
        self.input.add(obs.iter().chain(action).copied());
        self.delta.add(obs.iter().zip(next_obs).map(|(s, n)| n - s));
        self.input.export(&mut self.in_mean, &mut self.in_std);
        self.delta.export(&mut self.d_mean, &mut self.d_std);
    }

    /// The network's input for (`obs`, `act`) into `out`.
    pub(super) fn input(
        &self,
        obs: impl Iterator<Item = f32>,
        act: impl Iterator<Item = f32>,
        out: &mut [f32],
    ) {
        for (k, v) in obs.chain(act).enumerate() {
            out[k] = (v - self.in_mean[k]) / self.in_std[k];
        }
    }

    /// The network's target for a stored transition `obs -> next` into `out`.
    pub(super) fn target(&self, obs: &[f32], next: &[f32], out: &mut [f32]) {
        for k in 0..out.len() {
            out[k] = (next[k] - obs[k] - self.d_mean[k]) / self.d_std[k];
        }
    }

    /// Component `k` of the next observation the network's output `y` means from `obs_k`.
    pub(super) fn prediction(&self, obs_k: f64, k: usize, y: f32) -> f64 {
        obs_k + f64::from(self.d_mean[k]) + f64::from(self.d_std[k]) * f64::from(y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_match_the_two_pass_formulas_and_floor_the_deviation() {
        let mut n = Normaliser::new(2, 1);
        let data = [
            ([1.0, 5.0], [0.5], [2.0, 5.0]),
            ([3.0, 5.0], [-0.5], [3.5, 5.0]),
            ([2.0, 5.0], [0.0], [4.0, 5.0]),
        ];
        for (s, a, s2) in &data {
            n.add(s, a, s2);
        }
        let mut x = [0.0f32; 3];
        n.input([2.0f32, 5.0].into_iter(), [0.0f32].into_iter(), &mut x);
        // mean (2, 5, 0); sd (sqrt(2/3), 1e-4 floor, sqrt(1/6)).
        assert!(x.iter().all(|v| v.abs() < 1e-6), "{x:?}");
        n.input([3.0f32, 5.0].into_iter(), [0.5f32].into_iter(), &mut x);
        assert!((x[0] - 1.0 / (2.0f32 / 3.0).sqrt()).abs() < 1e-5, "{x:?}");
        assert_eq!(x[1], 0.0);
        // deltas (1, 0), (0.5, 0), (2, 0): mean 7/6.
        assert!((n.prediction(0.0, 0, 0.0) - 7.0 / 6.0).abs() < 1e-6);
        let (input, delta) = n.stats();
        let back = Normaliser::from_stats(input.clone(), delta.clone());
        assert_eq!((back.in_mean, back.in_std), (n.in_mean, n.in_std));
    }
}
