//! The crate's error type.

use std::path::PathBuf;

/// Everything that can go wrong in `defender-nn` on bad input (widths, files).
///
/// Shape mismatches between matrices passed to the hot-path methods (`forward`, `backward`,
/// `Adam::step`) are programming errors and panic instead; see each method's `# Panics`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NnError {
    /// The layer widths given to [`crate::Mlp::try_new`] do not describe a network.
    #[error("invalid MLP widths {widths:?}: {reason}")]
    InvalidWidths {
        /// The widths as given.
        widths: Vec<usize>,
        /// What is wrong with them.
        reason: &'static str,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not valid safetensors (or could not be serialised).
    #[error("{path}: not a valid safetensors file: {source}")]
    Format {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: safetensors::SafeTensorError,
    },
    /// A tensor the network (or optimiser) needs is not in the file.
    #[error("{path}: tensor `{name}` is missing (expected shape {expected:?}, f32)")]
    MissingTensor {
        /// The file.
        path: PathBuf,
        /// The tensor's name, e.g. `2.weight`.
        name: String,
        /// The shape it should have.
        expected: Vec<usize>,
    },
    /// The file holds a tensor this network has no place for.
    #[error("{path}: unexpected tensor `{name}` (expected only {expected})")]
    UnexpectedTensor {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// A description of the tensors that were expected.
        expected: String,
    },
    /// A tensor has the wrong shape.
    #[error("{path}: tensor `{name}` has shape {got:?}, expected {expected:?}")]
    TensorShape {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// The shape the network needs.
        expected: Vec<usize>,
        /// The shape in the file.
        got: Vec<usize>,
    },
    /// A tensor is not f32.
    #[error("{path}: tensor `{name}` has dtype {got}, expected F32")]
    TensorDtype {
        /// The file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// The dtype in the file.
        got: String,
    },
    /// A metadata entry of the file is missing or malformed.
    #[error("{path}: metadata `{key}`: expected {expected}, got {got:?}")]
    Metadata {
        /// The file.
        path: PathBuf,
        /// The metadata key.
        key: String,
        /// What was expected.
        expected: String,
        /// What the file holds (`None` if the key is absent).
        got: Option<String>,
    },
}

/// `Result` with [`NnError`].
pub type Result<T> = std::result::Result<T, NnError>;
