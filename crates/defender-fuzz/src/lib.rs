//! The fuzz targets: what `defender` reads from users, each as a function of raw bytes that must
//! return (accepting or refusing the input with an error) and never panic, abort or take
//! unbounded memory.
//!
//! Two callers share these functions: the cargo-fuzz project at the repository's root (`fuzz/`,
//! libFuzzer on nightly, one `fuzz_target!` per entry of [`TARGETS`]), and the replay on stable
//! (`tests/replay.rs`), which feeds every committed corpus file and regression through them in
//! seconds so that CI keeps a fixed crash fixed. docs/fuzzing.md says what each one feeds.

mod checkpoint;
mod config;
mod episode_set;
mod experiment;
pub mod files;
mod run_directory;
mod scratch;
pub mod seeds;
mod values;

pub use checkpoint::checkpoint;
pub use config::{config, strategy};
pub use episode_set::{episode_set, npy_arrays};
pub use experiment::{TASKS, experiment};
pub use run_directory::run_directory;
pub use values::experiment_values;

/// One fuzz target.
#[derive(Debug, Clone, Copy)]
pub struct Target {
    /// Its name: `fuzz/fuzz_targets/<name>.rs`, `fuzz/corpus/<name>/`.
    pub name: &'static str,
    /// Runs one input; `true` when the input was accepted (parsed and valid).
    pub run: fn(&[u8]) -> bool,
    /// The most bytes one input may make the target hold at once (the replay's bound; libFuzzer
    /// runs with `-malloc_limit_mb`).
    pub max_bytes: u64,
}

const MIB: u64 = 1 << 20;

/// Every target.
pub const TARGETS: &[Target] = &[
    Target { name: "run_directory", run: run_directory, max_bytes: 16 * MIB },
    Target { name: "config", run: config, max_bytes: 16 * MIB },
    Target { name: "episode_set", run: episode_set, max_bytes: 64 * MIB },
    Target { name: "npy_arrays", run: npy_arrays, max_bytes: 64 * MIB },
    Target { name: "checkpoint", run: checkpoint, max_bytes: 64 * MIB },
    Target { name: "experiment", run: experiment, max_bytes: 64 * MIB },
    Target { name: "experiment_values", run: experiment_values, max_bytes: 64 * MIB },
    Target { name: "strategy", run: strategy, max_bytes: MIB },
];

/// The target called `name`.
pub fn target(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}
