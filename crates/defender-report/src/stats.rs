//! Mean and standard deviation over seeds (with the bootstrap interval: [`Estimate`]), and
//! resampling curves onto a common step grid.

use crate::bootstrap::{Interval, bootstrap_ci};

/// Mean and standard deviation of a value over seeds.
///
/// The standard deviation is the population one (ddof = 0, numpy's default `np.std`): the paper
/// does not say which it used, and with three seeds the two differ by a factor sqrt(3/2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stat {
    /// Arithmetic mean.
    pub mean: f64,
    /// Population standard deviation (divides by n).
    pub std: f64,
    /// Number of values (seeds).
    pub n: usize,
}

impl Stat {
    /// The mean and population standard deviation of `values`; `None` when it is empty.
    pub fn of(values: &[f64]) -> Option<Stat> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        Some(Stat { mean, std: var.sqrt(), n: values.len() })
    }
}

/// A value over seeds as the report prints it: mean ± std ([`Stat`]) and the 95% percentile
/// bootstrap confidence interval of the mean (`crate::bootstrap`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Mean, population std and the number of seeds.
    pub stat: Stat,
    /// The 95% bootstrap interval of the mean over the seeds.
    pub ci: Interval,
}

impl Estimate {
    /// The estimate of `values`, one per seed; `None` when it is empty.
    pub fn of(values: &[f64]) -> Option<Estimate> {
        Some(Estimate { stat: Stat::of(values)?, ci: bootstrap_ci(values)? })
    }
}

/// Linear interpolation of the piecewise-linear curve through `(xs[i], ys[i])` at `x`, for `x`
/// within `[xs[0], xs[last]]` (`xs` non-decreasing); clamps outside. Where several points share
/// one `x`, the last one wins.
pub fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    debug_assert_eq!(xs.len(), ys.len());
    let n = xs.len();
    if n == 0 {
        return f64::NAN;
    }
    // First index with xs[i] > x.
    let i = xs.partition_point(|&v| v <= x);
    if i == 0 {
        return ys[0];
    }
    if i == n {
        return ys[n - 1];
    }
    let (x0, x1, y0, y1) = (xs[i - 1], xs[i], ys[i - 1], ys[i]);
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

/// `points` evenly spaced values from `start` to `end` inclusive (one value when they are equal).
pub fn linspace(start: f64, end: f64, points: usize) -> Vec<f64> {
    if points <= 1 || end <= start {
        return vec![start];
    }
    let step = (end - start) / (points - 1) as f64;
    (0..points).map(|i| if i + 1 == points { end } else { start + step * i as f64 }).collect()
}

/// The mean of the last `window` values at each position (fewer at the start).
pub fn rolling_mean(values: &[f64], window: usize) -> Vec<f64> {
    let window = window.max(1);
    let mut out = Vec::with_capacity(values.len());
    let mut sum = 0.0;
    for (i, v) in values.iter().enumerate() {
        sum += v;
        if i >= window {
            sum -= values[i - window];
        }
        out.push(sum / (i + 1).min(window) as f64);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_is_numpy_mean_and_std_ddof0() {
        // numpy: np.mean([1, 2, 4]) = 2.3333333333333335, np.std([1, 2, 4]) = 1.247219128924647
        let s = Stat::of(&[1.0, 2.0, 4.0]).unwrap();
        assert!((s.mean - 2.3333333333333335).abs() < 1e-12);
        assert!((s.std - 1.247219128924647).abs() < 1e-12);
        assert_eq!(s.n, 3);
        assert_eq!(Stat::of(&[5.0]).unwrap().std, 0.0);
        assert!(Stat::of(&[]).is_none());
    }

    #[test]
    fn interpolate_is_piecewise_linear_and_clamps() {
        let xs = [0.0, 10.0, 20.0];
        let ys = [0.0, 100.0, 50.0];
        assert_eq!(interpolate(&xs, &ys, 5.0), 50.0);
        assert_eq!(interpolate(&xs, &ys, 15.0), 75.0);
        assert_eq!(interpolate(&xs, &ys, 20.0), 50.0);
        assert_eq!(interpolate(&xs, &ys, -1.0), 0.0);
        assert_eq!(interpolate(&xs, &ys, 99.0), 50.0);
        assert_eq!(interpolate(&[1.0, 1.0], &[3.0, 4.0], 1.0), 4.0);
    }

    #[test]
    fn linspace_and_rolling_mean() {
        assert_eq!(linspace(0.0, 10.0, 3), vec![0.0, 5.0, 10.0]);
        assert_eq!(linspace(4.0, 4.0, 5), vec![4.0]);
        assert_eq!(rolling_mean(&[1.0, 3.0, 5.0, 7.0], 2), vec![1.0, 2.0, 4.0, 6.0]);
        assert_eq!(rolling_mean(&[1.0, 3.0], 0), vec![1.0, 3.0]);
    }
}
