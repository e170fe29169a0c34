//! The fuzz corpora replayed on stable, in seconds (part of `make test` and CI): every file of
//! `fuzz/corpus/<target>/` (the seeds and what libFuzzer kept) and of `fuzz/regressions/<target>/`
//! (inputs that once crashed a target, kept after the fix) goes through the same function the
//! fuzz target calls. None may panic, and none may make the target hold more memory at once than
//! its bound (measured on the replaying thread by a counting allocator).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use defender_fuzz::{TARGETS, Target};

#[global_allocator]
static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

/// The files of `fuzz/<kind>/<target>/`, sorted (none when the folder does not exist).
fn files(kind: &str, target: &str) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(fuzz_dir().join(kind).join(target)) else { return Vec::new() };
    let mut paths: Vec<PathBuf> =
        entries.filter_map(|e| Some(e.ok()?.path())).filter(|p| p.is_file()).collect();
    paths.sort();
    paths
}

/// Replays `target`'s corpus and regressions; returns how many inputs it accepted.
fn replay(target: &Target) -> usize {
    let corpus = files("corpus", target.name);
    assert!(!corpus.is_empty(), "fuzz/corpus/{} is empty: commit its seeds", target.name);
    let mut failures = Vec::new();
    let mut accepted = 0;
    for path in corpus.iter().chain(&files("regressions", target.name)) {
        let data = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let peak = alloc_counter::PeakBytes::start();
        let outcome = catch_unwind(AssertUnwindSafe(|| (target.run)(&data)));
        let used = peak.peak();
        match outcome {
            Err(_) => failures.push(format!("{}: panicked", path.display())),
            Ok(_) if used > target.max_bytes => failures.push(format!(
                "{}: held {used} bytes at once (bound {})",
                path.display(),
                target.max_bytes
            )),
            Ok(ok) => accepted += usize::from(ok),
        }
    }
    assert!(failures.is_empty(), "{}:\n  {}", target.name, failures.join("\n  "));
    accepted
}

fn replay_named(name: &str) {
    let target = defender_fuzz::target(name).unwrap_or_else(|| panic!("no target {name}"));
    let accepted = replay(target);
    // A harness that refuses everything (a broken fixture, a changed format) fuzzes nothing.
    assert!(accepted > 0, "{name}: no input of the corpus was accepted");
}

#[test]
fn run_directory() {
    replay_named("run_directory");
}

#[test]
fn config() {
    replay_named("config");
}

#[test]
fn episode_set() {
    replay_named("episode_set");
}

#[test]
fn npy_arrays() {
    replay_named("npy_arrays");
}

#[test]
fn checkpoint() {
    replay_named("checkpoint");
}

#[test]
fn experiment() {
    replay_named("experiment");
}

#[test]
fn experiment_values() {
    replay_named("experiment_values");
}

#[test]
fn strategy() {
    replay_named("strategy");
}

/// Every target is replayed above, every corpus folder is a target's, and every target has a
/// fuzz target file: a new target or a renamed folder cannot slip out of CI.
#[test]
fn corpora_targets_and_fuzz_targets_match() {
    let mut listed: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
    listed.sort_unstable();
    let source = include_str!("replay.rs");
    for name in &listed {
        assert!(source.contains(&format!("replay_named(\"{name}\")")), "{name} is not replayed");
        let file = fuzz_dir().join("fuzz_targets").join(format!("{name}.rs"));
        assert!(file.is_file(), "{} is missing", file.display());
    }
    for kind in ["corpus", "regressions"] {
        let Ok(entries) = std::fs::read_dir(fuzz_dir().join(kind)) else { continue };
        for entry in entries.filter_map(Result::ok) {
            let name = entry.file_name().to_string_lossy().into_owned();
            assert!(listed.contains(&name.as_str()), "fuzz/{kind}/{name} is no target's");
        }
    }
}

/// The bound bites: an input that makes a target allocate beyond it is reported.
#[test]
fn the_memory_bound_is_measured() {
    let peak = alloc_counter::PeakBytes::start();
    let big = vec![1u8; 3 << 20];
    assert!(peak.peak() >= 3 << 20 && big[0] == 1);
}
