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
    /// Saving or loading an environment's checkpoint state failed.
    #[error("environment state {path}: {reason}")]
    State {
        /// The file or directory.
        path: std::path::PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// Result of the environment API.
pub type Result<T, E = EnvError> = std::result::Result<T, E>;

/// Checks length and finiteness of a vector handed to an environment (actions, states, replay
/// rows): the one check every environment and buffer of the workspace uses.
///
/// # Errors
/// [`EnvError::LengthMismatch`] or [`EnvError::NonFinite`], naming `name`.
pub fn check_vector(name: &str, values: &[f64], expected: usize) -> Result<()> {
    if values.len() != expected {
        return Err(EnvError::LengthMismatch { name: name.into(), expected, got: values.len() });
    }
    if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(EnvError::NonFinite { name: name.into(), index, value });
    }
    Ok(())
}

/// What can go wrong in training: the environment, a network, a checkpoint, a configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RlError {
    /// The environment failed.
    #[error(transparent)]
    Env(#[from] EnvError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: std::path::PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A hyperparameter or trainer setting is out of range.
    #[error("invalid configuration: {field} = {value}: {expected}")]
    Config {
        /// The field (SB3 name).
        field: &'static str,
        /// The value given.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The environment does not fit the agent (unbounded action space, dimensions differ).
    #[error("environment '{env}' does not fit: {reason}")]
    Incompatible {
        /// The environment id.
        env: String,
        /// What is wrong.
        reason: String,
    },
    /// A checkpoint is missing a file, or a file does not match the agent it is loaded into.
    #[error("checkpoint {path}: {reason}")]
    Checkpoint {
        /// The checkpoint file or directory.
        path: std::path::PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A network operation failed (widths, safetensors I/O).
    #[error(transparent)]
    Nn(#[from] defender_nn::NnError),
    /// A training hook returned an error.
    #[error("hook {hook}: {source}")]
    Hook {
        /// Which callback.
        hook: &'static str,
        /// What the hook reported.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The environment returned a NaN or infinite reward or observation: the run stops before it
    /// reaches the agent's replay buffer (and the tables); its last checkpoint is kept.
    #[error(
        "the environment returned a non-finite {field} ({value}, element {index}) at step {step} \
         (episode {episode}); the run stops here, and its last checkpoint is kept"
    )]
    NonFiniteStep {
        /// `reward` or `observation`.
        field: &'static str,
        /// The element (0 for the reward).
        index: usize,
        /// The value.
        value: f64,
        /// The run's step count, this step included.
        step: u64,
        /// The episode (0-based).
        episode: u64,
    },
    /// Training produced a non-finite value (diverged).
    #[error("non-finite {what} at update {update}")]
    Diverged {
        /// What became NaN or infinite.
        what: &'static str,
        /// The gradient update count.
        update: u64,
    },
}

impl RlError {
    /// An I/O error on `path`.
    pub(crate) fn io(path: impl Into<std::path::PathBuf>, source: std::io::Error) -> Self {
        Self::Io { path: path.into(), source }
    }
}

impl From<(std::path::PathBuf, std::io::Error)> for RlError {
    fn from((path, source): (std::path::PathBuf, std::io::Error)) -> Self {
        Self::Io { path, source }
    }
}

impl RlError {
    /// A checkpoint error on `path`.
    pub(crate) fn checkpoint(path: impl Into<std::path::PathBuf>, reason: impl Into<String>) -> Self {
        Self::Checkpoint { path: path.into(), reason: reason.into() }
    }
}
