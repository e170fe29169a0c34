//! The 95% percentile bootstrap confidence interval of a mean over seeds, as rliable
//! (Agarwal et al., 2021, "Deep RL at the edge of the statistical precipice") computes it for one
//! task: draw the row's runs with replacement (as many as it has), take the mean, repeat
//! [`RESAMPLES`] times, and report the 2.5th and 97.5th percentiles of those means (numpy's
//! default linear interpolation between order statistics).
//!
//! The resamples come from a fixed seed ([`SEED`]) through SplitMix64, a generator small enough
//! to carry here, so the interval of a row depends on its values alone: the same runs give the
//! same report on any machine, whatever else is in it. With 3 seeds there are only 10 distinct
//! resampled means, so the interval is coarse; it is still what tells a reader whether 3 seeds
//! separate two rows (overlapping intervals: they do not).

/// Resamples per interval (rliable's default `reps`).
pub const RESAMPLES: usize = 50_000;

/// The seed of the resampling generator.
pub const SEED: u64 = 0;

/// The confidence level of [`bootstrap_ci`].
pub const LEVEL: f64 = 0.95;

/// A confidence interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

/// The 95% percentile bootstrap interval of the mean of `values` with [`RESAMPLES`] resamples
/// drawn from [`SEED`]; `None` when `values` is empty. One value gives `[v, v]`.
pub fn bootstrap_ci(values: &[f64]) -> Option<Interval> {
    bootstrap_ci_with(values, RESAMPLES, SEED, LEVEL)
}

/// [`bootstrap_ci`] with its parameters: `resamples` resamples (at least 1) from `seed`, the
/// central `level` (in (0, 1)) of the resampled means.
pub fn bootstrap_ci_with(values: &[f64], resamples: usize, seed: u64, level: f64) -> Option<Interval> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mut rng = SplitMix64(seed);
    let mut indices = vec![0usize; n];
    let draws = (0..resamples.max(1)).map(|_| {
        indices.iter_mut().for_each(|i| *i = rng.below(n));
        indices.clone()
    });
    percentile_ci(values, draws, level)
}

/// The percentile interval of the mean of `values` over the given resamples, each a list of
/// indices into `values` (drawn with replacement): the `(1 - level) / 2` and `(1 + level) / 2`
/// quantiles of the resampled means. `None` without values or resamples. Separate from the
/// generator so that a test can hand it resamples chosen by hand.
pub fn percentile_ci<I, R>(values: &[f64], resamples: I, level: f64) -> Option<Interval>
where
    I: IntoIterator<Item = R>,
    R: AsRef<[usize]>,
{
    if values.is_empty() {
        return None;
    }
    let mut means: Vec<f64> = resamples
        .into_iter()
        .map(|draw| {
            let draw = draw.as_ref();
            draw.iter().map(|&i| values[i]).sum::<f64>() / draw.len() as f64
        })
        .collect();
    if means.is_empty() {
        return None;
    }
    let tail = (1.0 - level) / 2.0;
    let lo = quantile(&mut means, tail);
    let hi = quantile(&mut means, 1.0 - tail);
    Some(Interval { lo, hi })
}

/// The `q`-quantile of `values` (`q` in [0, 1]) by numpy's default rule (`method="linear"`): the
/// value at position `q (n - 1)` of the sorted values, interpolated between its neighbours.
/// Reorders `values`.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    let h = q.clamp(0.0, 1.0) * (n - 1) as f64;
    let k = h.floor() as usize;
    // Selection instead of a full sort: O(n) for the 50,000 means of a resampling.
    let (_, &mut below, above) = values.select_nth_unstable_by(k, f64::total_cmp);
    let frac = h - k as f64;
    if frac == 0.0 || above.is_empty() {
        return below;
    }
    let next = above.iter().copied().fold(f64::INFINITY, f64::min);
    below + frac * (next - below)
}

/// SplitMix64 (Steele, Lea and Flood, 2014; the seeding generator of xoshiro): 64 bits of state,
/// passes BigCrush, and is defined by these few lines, so the resamples never change with a
/// dependency's version.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform index below `n` by Lemire's multiply-shift (its bias, n / 2^64, is far below
    /// anything 50,000 resamples can show).
    fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next()) * n as u128) >> 64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_matches_its_reference_output() {
        // The reference implementation (Vigna, splitmix64.c) seeded with 0 starts with these.
        let mut rng = SplitMix64(0);
        assert_eq!(rng.next(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(rng.next(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(rng.next(), 0x06C4_5D18_8009_454F);
    }

    #[test]
    fn quantile_is_numpys_linear_rule() {
        // np.percentile([1, 2, 3, 4], [0, 25, 50, 97.5, 100]) = [1, 1.75, 2.5, 3.925, 4]
        for (q, want) in [(0.0, 1.0), (0.25, 1.75), (0.5, 2.5), (0.975, 3.925), (1.0, 4.0)] {
            let mut v = vec![4.0, 1.0, 3.0, 2.0];
            assert!((quantile(&mut v, q) - want).abs() < 1e-12, "q = {q}");
        }
        assert!(quantile(&mut [], 0.5).is_nan());
        assert_eq!(quantile(&mut [7.0], 0.3), 7.0);
    }
}
