//! FastDTW (Salvador & Chan), exactly as the PyPI `fastdtw` package 0.3.4 computes it: the
//! approximate DTW the DEFENDER paper's code used (`fastdtw(x, y, radius=1, dist=None)`).
//! docs/decisions-authors.md ("FastDTW as the package computes it") says which of the package's two
//! implementations this follows and why.

use crate::error::{DtwError, Result, check_sequence};
use crate::isa::isa;
use crate::metric::Metric;
use crate::pyramid::Pyramid;
use crate::solver::Solver;

/// FastDTW settings: the `radius` around the coarser level's path and the point [`Metric`].
///
/// The default is the package's own, `fastdtw(x, y)` on vectors: radius 1, L1. A radius of at
/// least `max(n, m) - 2` (e.g. `usize::MAX`) never coarsens: that is the package's exact `dtw`.
///
/// ```
/// use defender_dtw::{FastDtw, Metric};
/// let x = [1.0_f32, 2.0, 3.0, 4.0, 5.0];
/// let y = [2.0_f32, 3.0, 4.0];
/// // The package's docstring example: fastdtw(x, y) == 2.0.
/// assert_eq!(FastDtw::default().distance(&x, &y, 1)?, 2.0);
/// let exact = FastDtw::new(usize::MAX, Metric::L2);
/// assert_eq!(exact.distance(&x, &y, 1)?, 2.0);
/// # Ok::<(), defender_dtw::DtwError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FastDtw {
    /// Cells around the coarser path (in every direction) that the finer level evaluates.
    pub radius: usize,
    /// The point distance.
    pub metric: Metric,
}

impl Default for FastDtw {
    fn default() -> Self {
        Self { radius: 1, metric: Metric::L1 }
    }
}

impl FastDtw {
    /// FastDTW with this radius and point metric.
    #[must_use]
    pub fn new(radius: usize, metric: Metric) -> Self {
        Self { radius, metric }
    }

    /// The same settings with another radius.
    #[must_use]
    pub fn with_radius(self, radius: usize) -> Self {
        Self { radius, ..self }
    }

    /// The same settings with another point metric.
    #[must_use]
    pub fn with_metric(self, metric: Metric) -> Self {
        Self { metric, ..self }
    }

    /// The FastDTW cost between `x` and `y`, row-major sequences of `dim`-vectors, computed in
    /// f64 like the package (which converts its inputs to float64). Same as [`fastdtw`].
    ///
    /// # Errors
    /// [`DtwError::ZeroDimension`], [`DtwError::EmptySequence`], [`DtwError::LengthNotMultiple`],
    /// [`DtwError::NonFinite`] for bad inputs; [`DtwError::NoWarpingPath`] where the package
    /// fails (radius 0 with an odd coarsened length).
    pub fn distance(&self, x: &[f32], y: &[f32], dim: usize) -> Result<f64> {
        fastdtw(x, y, dim, self)
    }
}

/// FastDTW cost between `x` and `y` (row-major sequences of `dim`-vectors) under `settings`:
/// the first value of the package's `fastdtw(x, y, radius, dist)`, with `dist=None` for
/// [`Metric::L1`] and `dist=2` for [`Metric::L2`]. Allocates its scratch; for many calls, use
/// [`crate::FastReferences`].
///
/// # Errors
/// As [`FastDtw::distance`].
pub fn fastdtw(x: &[f32], y: &[f32], dim: usize, settings: &FastDtw) -> Result<f64> {
    let n = check_sequence("x", x, dim)?;
    let m = check_sequence("y", y, dim)?;
    let (px, py) = (Pyramid::new(x, dim), Pyramid::new(y, dim));
    Solver::default()
        .fastdtw(isa(), &px, &py, settings.radius, settings.metric)
        .ok_or_else(|| DtwError::NoWarpingPath { name: "x and y".into(), n, m, radius: settings.radius })
}
