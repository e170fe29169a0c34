//! Errors of the method crate.

use std::path::PathBuf;

/// What can go wrong in the method: bad files, bad names, bad configurations, and errors of the
/// substrate crates (DTW, networks, environments) passed through.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DefenderError {
    /// Reading or writing a file failed at the operating-system level.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A file was readable but is not a valid archive or array (bad zip, bad .npy header, ...).
    #[error("{path}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        what: String,
    },
    /// An array of an episode-set file (SPEC section 8) breaks a rule.
    #[error("{path}: array '{array}': expected {expected}, got {got}")]
    InvalidArray {
        /// The file (or `<memory>` for a set built in memory).
        path: PathBuf,
        /// The array (`obs`, `act`, `rew`, `ep_len`, `crashed`, `meta`).
        array: &'static str,
        /// What the rule asks for.
        expected: String,
        /// What was found.
        got: String,
    },
    /// A demonstration set lacks one of the two groups the filter needs (SPEC section 1).
    #[error(
        "{path}: the {group} group is empty (crashed = {crashed}); a demonstration set needs both safe and unsafe demonstrations"
    )]
    MissingGroup {
        /// The file.
        path: PathBuf,
        /// `safe` or `unsafe`.
        group: &'static str,
        /// The `crashed` value that marks the group.
        crashed: bool,
    },
    /// More demonstrations per group were asked for than the set holds.
    #[error(
        "{path}: {setting} asks for {asked} demonstrations per group, but the {group} group has only {available}"
    )]
    NotEnoughDemos {
        /// The file.
        path: PathBuf,
        /// What asked for them, as the user sets it (`num_demos`).
        setting: &'static str,
        /// `safe` or `unsafe`.
        group: &'static str,
        /// The number asked for.
        asked: usize,
        /// The number available.
        available: usize,
    },
    /// A dimension or identifier does not match what it must match.
    #[error("{what}: expected {expected}, got {got}")]
    Mismatch {
        /// What was compared (e.g. "demonstrations obs_dim vs environment").
        what: String,
        /// The expected value.
        expected: String,
        /// The value found.
        got: String,
    },
    /// A name (window, method, strategy, mode) that does not parse.
    #[error("unknown {kind} '{name}'; valid forms: {valid}")]
    UnknownName {
        /// `window`, `aggregation`, `method`, `strategy`, `mode` or `scaling`.
        kind: &'static str,
        /// The name given.
        name: String,
        /// The valid forms.
        valid: String,
    },
    /// A configuration value out of its range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The thread that trains the dynamics model in the background stopped or failed.
    #[error("dynamics model thread: {0}")]
    Worker(String),
    /// A checkpoint that cannot be restored.
    #[error("checkpoint {path}: {what}")]
    Checkpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// An error of the DTW kernels.
    #[error(transparent)]
    Dtw(#[from] defender_dtw::DtwError),
    /// An error of the neural-network crate.
    #[error(transparent)]
    Nn(#[from] defender_nn::NnError),
    /// An error of the wrapped environment.
    #[error(transparent)]
    Env(#[from] defender_rl::EnvError),
}

/// Result of the method crate.
pub type Result<T, E = DefenderError> = std::result::Result<T, E>;

impl DefenderError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io { path: path.into(), source }
    }
}
