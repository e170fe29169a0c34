//! OmniSafe 0.5's cost normalisation (`envs/wrapper.py` `CostNormalize`, `common/normalizer.py`
//! `Normalizer((), clip=5)`): each step's cost is pushed into running statistics, then replaced
//! by `(c - mean) / max(std, 0.01)` clipped to +-5, `std` the sample standard deviation of every
//! cost pushed so far; the very first cost passes unchanged. Here in f64 (OmniSafe: float32
//! tensors), the same updates (Chan et al.'s batch merge with batches of one).

use serde::{Deserialize, Serialize};

/// The clip of OmniSafe's cost normaliser.
pub const CLIP: f64 = 5.0;

/// Running mean and sum of squared deviations of the costs seen. Kept by checkpoints.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CostNormalizer {
    count: u64,
    mean: f64,
    sumsq: f64,
}

impl CostNormalizer {
    /// Pushes `cost` and returns it normalised.
    pub fn normalize(&mut self, cost: f64) -> f64 {
        if self.count == 0 {
            self.mean = cost;
            self.sumsq = 0.0;
        } else {
            let n = self.count as f64;
            let delta = cost - self.mean;
            self.mean += delta / (n + 1.0);
            self.sumsq += delta * delta * n / (n + 1.0);
        }
        self.count += 1;
        if self.count <= 1 {
            return cost;
        }
        let std = (self.sumsq / (self.count - 1) as f64).sqrt().max(1e-2);
        ((cost - self.mean) / std).clamp(-CLIP, CLIP)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_sample_statistics_and_clips() {
        let mut n = CostNormalizer::default();
        assert_eq!(n.normalize(1.0), 1.0, "the first cost passes unchanged");
        // [1, 0]: mean 0.5, sample std sqrt(0.5).
        let second = n.normalize(0.0);
        assert!((second - (-0.5 / 0.5f64.sqrt())).abs() < 1e-12, "{second}");
        // [1, 0, 0, 0]: mean 0.25, sample variance (0.5625 + 3 * 0.0625) / 3 = 0.25.
        n.normalize(0.0);
        let fourth = n.normalize(0.0);
        assert!((fourth - (-0.25 / 0.5)).abs() < 1e-12, "{fourth}");
        // A rare cost among many zeros is clipped at 5.
        let mut rare = CostNormalizer::default();
        for _ in 0..1000 {
            rare.normalize(0.0);
        }
        assert_eq!(rare.normalize(1.0), CLIP);
        // Constant costs: std floors at 0.01.
        let mut flat = CostNormalizer::default();
        flat.normalize(2.0);
        assert_eq!(flat.normalize(2.0), 0.0);
    }
}
