//! Continuous box spaces (Gymnasium's `Box`).

use crate::error::{EnvError, Result, check_vector};

/// A box in R^n with per-dimension bounds (which may be infinite, as for MuJoCo observations).
#[derive(Debug, Clone, PartialEq)]
pub struct BoxSpace {
    low: Vec<f64>,
    high: Vec<f64>,
}

impl BoxSpace {
    /// A box with the given bounds.
    ///
    /// # Errors
    /// The bounds differ in length, are NaN, or `low > high` somewhere.
    pub fn new(low: Vec<f64>, high: Vec<f64>) -> Result<Self> {
        if low.len() != high.len() {
            return Err(EnvError::LengthMismatch {
                name: "BoxSpace high".into(),
                expected: low.len(),
                got: high.len(),
            });
        }
        if let Some(i) = (0..low.len()).find(|&i| low[i].is_nan() || high[i].is_nan() || low[i] > high[i]) {
            return Err(EnvError::Simulator(format!(
                "BoxSpace bound {i}: low {} must be <= high {}",
                low[i], high[i]
            )));
        }
        Ok(Self { low, high })
    }

    /// The unbounded box of dimension `dim` (MuJoCo observation spaces).
    pub fn unbounded(dim: usize) -> Self {
        Self { low: vec![f64::NEG_INFINITY; dim], high: vec![f64::INFINITY; dim] }
    }

    /// Number of dimensions.
    pub fn dim(&self) -> usize {
        self.low.len()
    }

    /// Lower bounds.
    pub fn low(&self) -> &[f64] {
        &self.low
    }

    /// Upper bounds.
    pub fn high(&self) -> &[f64] {
        &self.high
    }

    /// Whether every bound is finite (action spaces must be, for squashing policies).
    pub fn is_bounded(&self) -> bool {
        self.low.iter().chain(&self.high).all(|v| v.is_finite())
    }

    /// Whether `x` has the right length and lies inside the box.
    pub fn contains(&self, x: &[f64]) -> bool {
        x.len() == self.dim() && x.iter().zip(&self.low).zip(&self.high).all(|((v, l), h)| v >= l && v <= h)
    }

    /// Checks that `x` has the right length and finite values.
    ///
    /// # Errors
    /// [`EnvError::LengthMismatch`] or [`EnvError::NonFinite`], naming `what`.
    pub fn check(&self, what: &str, x: &[f64]) -> Result<()> {
        check_vector(what, x, self.dim())
    }

    /// SB3's `unscale_action`: an action of a squashing policy, in `[-1, 1]`, to this box's
    /// bounds, `low + (a + 1) / 2 (high - low)`, into `out` (zipped: extra entries are left alone).
    pub fn unscale(&self, action: &[f32], out: &mut [f64]) {
        for (((o, &a), &l), &h) in out.iter_mut().zip(action).zip(&self.low).zip(&self.high) {
            *o = l + (f64::from(a) + 1.0) * 0.5 * (h - l);
        }
    }
}
