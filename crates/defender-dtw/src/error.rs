//! The crate's error type: every problem with user input is reported here, never as a panic.

/// Errors of `defender-dtw`, returned at the API boundary (construction, `push`, batch calls).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DtwError {
    /// The vector dimension was zero; every sequence element needs at least one component.
    #[error("dimension must be >= 1, got 0")]
    ZeroDimension,
    /// A sequence had no elements.
    #[error("{name} is empty; DTW needs at least one element")]
    EmptySequence {
        /// Which sequence (e.g. "x", "y", "reference 3").
        name: String,
    },
    /// A row-major buffer's length is not a multiple of the dimension.
    #[error("{name} has {len} values, which is not a multiple of the dimension {dim}")]
    LengthNotMultiple {
        /// Which sequence.
        name: String,
        /// Its number of values.
        len: usize,
        /// The expected dimension.
        dim: usize,
    },
    /// An element had the wrong number of components.
    #[error("{name} has {got} values, expected {expected} (the dimension)")]
    DimensionMismatch {
        /// Which element or sequence.
        name: String,
        /// The expected number of values.
        expected: usize,
        /// The number given.
        got: usize,
    },
    /// A value was NaN or infinite.
    #[error("{name} has a non-finite value ({value}) at index {index}; inputs must be finite")]
    NonFinite {
        /// Which sequence or element.
        name: String,
        /// Flat index of the value in the given buffer.
        index: usize,
        /// The offending value.
        value: f32,
    },
    /// A reference set was built from no sequences.
    #[error("a reference set needs at least one sequence, got none")]
    NoReferences,
    /// A window length was zero (`Last(0)`), or a band / threshold setting was invalid.
    #[error("invalid setting {name}: {reason}")]
    InvalidSetting {
        /// The setting (e.g. `views[2].query`).
        name: String,
        /// What was expected.
        reason: String,
    },
    /// FastDTW's window does not reach the last cell: with radius 0, a coarsened length that is odd
    /// leaves the last row or column out (the `fastdtw` package raises `IndexError` there).
    #[error(
        "fastdtw with radius {radius} has no warping path for {name} ({n} x {m} elements): its window \
         misses the last cell when a coarsened length is odd (the fastdtw package raises IndexError \
         here); use radius >= 1"
    )]
    NoWarpingPath {
        /// Which pair (e.g. "x and y", "reference 3").
        name: String,
        /// The query's number of elements.
        n: usize,
        /// The reference's number of elements.
        m: usize,
        /// The radius used.
        radius: usize,
    },
}

/// `Result` with [`DtwError`].
pub type Result<T> = std::result::Result<T, DtwError>;

/// Checks that `values` is a non-empty row-major sequence of `dim`-vectors with finite values.
/// Returns its number of elements.
pub(crate) fn check_sequence(name: &str, values: &[f32], dim: usize) -> Result<usize> {
    if dim == 0 {
        return Err(DtwError::ZeroDimension);
    }
    if values.is_empty() {
        return Err(DtwError::EmptySequence { name: name.to_owned() });
    }
    if !values.len().is_multiple_of(dim) {
        return Err(DtwError::LengthNotMultiple { name: name.to_owned(), len: values.len(), dim });
    }
    check_finite(name, values)?;
    Ok(values.len() / dim)
}

/// Checks that every value is finite.
pub(crate) fn check_finite(name: &str, values: &[f32]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(DtwError::NonFinite { name: name.to_owned(), index, value: values[index] }),
        None => Ok(()),
    }
}
