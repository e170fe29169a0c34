//! The crate's error type: every message names the file (or directory) and what was expected.

use std::path::PathBuf;

/// Everything that can go wrong while reading run directories or writing a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// A path given on the command line does not exist.
    #[error("{path}: no such file or directory")]
    NoSuchPath {
        /// The path as given.
        path: PathBuf,
    },
    /// A path holds no run directory (no `summary.json` in it, nor one or two levels below it).
    #[error("{path}: no run directory found (looked for summary.json in it and one or two levels below it)")]
    NoRuns {
        /// The path searched.
        path: PathBuf,
    },
    /// A run directory lacks one of the four files of the contract.
    #[error(
        "{path}: missing; a run directory holds config.toml, metrics.csv, eval.csv and summary.json \
         (docs/run-directory.md)"
    )]
    MissingFile {
        /// The file that should exist.
        path: PathBuf,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// `config.toml` is not valid TOML or lacks a key the report needs.
    #[error("{path}: {source}")]
    Toml {
        /// The file.
        path: PathBuf,
        /// The parser's error (it names the key and the line).
        source: Box<toml::de::Error>,
    },
    /// `summary.json` is not valid JSON or lacks a field the report needs.
    #[error("{path}: {source}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The parser's error (it names the field, line and column).
        source: serde_json::Error,
    },
    /// A CSV file's header lacks a column of the contract.
    #[error("{path}: bad header {got:?}: expected the columns {expected:?} (missing column {missing:?})")]
    CsvHeader {
        /// The file.
        path: PathBuf,
        /// The header the contract prescribes.
        expected: &'static str,
        /// The header found (the first line).
        got: String,
        /// The first column of `expected` that was not found.
        missing: &'static str,
    },
    /// A CSV row cannot be read.
    #[error("{path}:{line}: {message}")]
    CsvRow {
        /// The file.
        path: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The files of a run directory are readable but contradict the contract or each other.
    #[error("{path}: {message}")]
    Invalid {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The run is still in progress or was stopped (`"complete": false` in `summary.json`).
    #[error("{dir}: incomplete run (summary.json has \"complete\": false)")]
    Incomplete {
        /// The run directory.
        dir: PathBuf,
    },
    /// Two run directories describe the same experiment (task, algorithm, budget, strategy, seed).
    #[error("{first} and {second} are the same run ({what}); pass only one of them")]
    Duplicate {
        /// The first run directory.
        first: PathBuf,
        /// The second one.
        second: PathBuf,
        /// The experiment they share.
        what: String,
    },
    /// Nothing to report: every run found was skipped.
    #[error("no complete run to report")]
    Empty,
    /// Drawing a plot failed.
    #[error("{path}: drawing the plot failed: {message}")]
    Plot {
        /// The plot file.
        path: PathBuf,
        /// The backend's error.
        message: String,
    },
}

/// The crate's result type.
pub type Result<T, E = ReportError> = std::result::Result<T, E>;

pub(crate) fn io_err(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> ReportError {
    let path = path.into();
    move |source| ReportError::Io { path, source }
}
