//! Batch DTW between two sequences: the settings builder [`Dtw`] and the function [`dtw`].

use crate::error::{DtwError, Result, check_sequence};
use crate::isa::isa;
use crate::kernel::{self, Problem, RevSeq};
use crate::metric::Metric;

/// How to align two sequences: Euclidean local cost (or L1, [`Dtw::with_metric`]), steps (1,0), (0,1), (1,1) of weight 1
/// (SPEC section 2), plus the optional Sakoe-Chiba band and early-abandon threshold.
///
/// ```
/// use defender_dtw::Dtw;
/// let x = [0.0_f32, 0.0, 1.0, 1.0, 2.0, 2.0]; // 3 elements of dimension 2
/// let y = [0.0_f32, 0.0, 2.0, 2.0];           // 2 elements
/// let cost = Dtw::euclidean().distance(&x, &y, 2)?;
/// assert!((cost - 2.0_f32.sqrt()).abs() < 1e-6);
/// assert_eq!(Dtw::euclidean().with_max_cost(1.0).distance(&x, &y, 2)?, f32::INFINITY);
/// # Ok::<(), defender_dtw::DtwError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dtw {
    /// Sakoe-Chiba band half-width `w`: only cells with `|i - j| <= w` are allowed (`None`: no
    /// band). The result is `+inf` when the end cell is outside the band (`|n - m| > w`).
    pub band: Option<usize>,
    /// Early-abandon threshold: the result is `+inf` whenever the cost exceeds it, and the
    /// computation stops as soon as that is certain (`None`: never abandon).
    pub max_cost: Option<f32>,
    /// The local cost: [`Metric::L2`] (SPEC section 2, the default) or [`Metric::L1`] (the
    /// `fastdtw` package's default on vectors, which the paper's code used).
    pub metric: Metric,
}

impl Default for Dtw {
    fn default() -> Self {
        Self::euclidean()
    }
}

impl Dtw {
    /// The SPEC's DTW: Euclidean local cost `||x_i - y_j||_2`, no band, no threshold. Equals
    /// dtw-python's `dtw(x, y, dist_method="euclidean", step_pattern=symmetric1).distance`.
    #[must_use]
    pub fn euclidean() -> Self {
        Self { band: None, max_cost: None, metric: Metric::L2 }
    }

    /// Restricts the warping path to the Sakoe-Chiba band `|i - j| <= half_width`.
    #[must_use]
    pub fn with_band(self, half_width: usize) -> Self {
        Self { band: Some(half_width), ..self }
    }

    /// Returns `+inf` as soon as the cost is certain to exceed `max_cost`.
    #[must_use]
    pub fn with_max_cost(self, max_cost: f32) -> Self {
        Self { max_cost: Some(max_cost), ..self }
    }

    /// The same settings with another local cost. The L1 kernel is the Euclidean one with `|a - b|`
    /// summed in place of `(a - b)^2` and no square root, in f32 like it.
    #[must_use]
    pub fn with_metric(self, metric: Metric) -> Self {
        Self { metric, ..self }
    }

    pub(crate) fn check(&self) -> Result<()> {
        match self.max_cost {
            Some(c) if c.is_nan() => Err(DtwError::InvalidSetting {
                name: "max_cost".into(),
                reason: "expected a number, got NaN".into(),
            }),
            _ => Ok(()),
        }
    }

    pub(crate) fn threshold(&self) -> f32 {
        self.max_cost.unwrap_or(f32::INFINITY)
    }

    /// DTW cost between `x` and `y`, two row-major sequences of `dim`-vectors
    /// (`x.len() = n * dim`, `y.len() = m * dim`). Same as [`dtw`].
    ///
    /// # Errors
    /// [`DtwError::ZeroDimension`], [`DtwError::EmptySequence`], [`DtwError::LengthNotMultiple`]
    /// for a length that is not a multiple of `dim`, [`DtwError::NonFinite`] for NaN or infinite
    /// values, [`DtwError::InvalidSetting`] for a NaN `max_cost`.
    pub fn distance(&self, x: &[f32], y: &[f32], dim: usize) -> Result<f32> {
        dtw(x, y, dim, self)
    }
}

/// DTW cost between `x` and `y` (row-major sequences of `dim`-vectors) under `settings`:
/// `D(n-1, m-1)` of SPEC section 2, `+inf` if banded out or abandoned.
///
/// # Errors
/// As [`Dtw::distance`]: zero dimension, empty or ragged sequences, non-finite values, NaN
/// threshold.
pub fn dtw(x: &[f32], y: &[f32], dim: usize, settings: &Dtw) -> Result<f32> {
    settings.check()?;
    check_sequence("x", x, dim)?;
    let m = check_sequence("y", y, dim)?;
    let mut storage = Vec::new();
    RevSeq::store(y, dim, &mut storage);
    let problem = Problem {
        x,
        y: RevSeq { data: &storage, stride: m + 2 * crate::lanes::PAD },
        dim,
        cols: m,
        band: settings.band,
        max_cost: settings.threshold(),
        metric: settings.metric,
    };
    Ok(kernel::dtw_cost(isa(), &problem, &mut Vec::new()))
}
