//! Errors of the environment API.

/// What can go wrong when talking to an environment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EnvError {
    /// An action (or other vector) had the wrong number of elements.
    #[error("{name}: expected {expected} elements, got {got}")]
    LengthMismatch {
        /// What the vector is (e.g. "action").
        name: String,
        /// The length the environment expects.
        expected: usize,
        /// The length it was given.
        got: usize,
    },
    /// A value was NaN or infinite.
    #[error("{name}: element {index} is not finite ({value})")]
    NonFinite {
        /// What the vector is.
        name: String,
        /// The offending index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// `step` was called before `reset`, or after the episode ended without a new `reset`.
    #[error("step called on an environment that needs reset (call reset first)")]
    NeedsReset,
    /// An environment id that no registry knows.
    #[error("unknown environment id '{id}'; known ids: {known}")]
    UnknownEnv {
        /// The id asked for.
        id: String,
        /// The ids that exist, comma-separated.
        known: String,
    },
    /// The simulator failed (model loading, numerical error it cannot recover from, ...).
    #[error("simulator error: {0}")]
    Simulator(String),
}

/// Result of the environment API.
pub type Result<T, E = EnvError> = std::result::Result<T, E>;

/// Checks length and finiteness of a vector handed to an environment.
///
/// # Errors
/// [`EnvError::LengthMismatch`] or [`EnvError::NonFinite`].
pub(crate) fn check_vector(name: &str, values: &[f64], expected: usize) -> Result<()> {
    if values.len() != expected {
        return Err(EnvError::LengthMismatch { name: name.into(), expected, got: values.len() });
    }
    if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(EnvError::NonFinite { name: name.into(), index, value });
    }
    Ok(())
}
