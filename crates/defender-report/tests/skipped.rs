//! Run directories left out of a report, each with its state: still running (its lock held),
//! stopped (a checkpoint to resume from) or broken (neither), whether `summary.json` is missing
//! or says `"complete": false`.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use std::path::{Path, PathBuf};

use common::{A, RunSpec};
use defender_io::DirLock;
use defender_report::{SkipKind, SkippedRun, find_run_dirs, load_runs};

fn incomplete(dir: &Path) {
    std::fs::write(dir.join("summary.json"), "{\"env\": \"Hopper-v5\", \"complete\": false}").unwrap();
}

fn skipped_of(root: &Path) -> Vec<SkippedRun> {
    load_runs(&[root]).unwrap().skipped
}

fn one(skipped: &[SkippedRun], dir: &PathBuf) -> SkippedRun {
    skipped
        .iter()
        .find(|s| &s.dir == dir)
        .unwrap_or_else(|| panic!("{} not skipped: {skipped:?}", dir.display()))
        .clone()
}

#[test]
fn each_skipped_directory_says_whether_it_runs_stopped_or_broke() {
    let root = tempfile::tempdir().unwrap();
    let root = root.path();
    let complete = RunSpec::new("sac", 0, None).write(root);

    // Running: its lock is held (as `defender train` holds it), summary.json says incomplete.
    let live = RunSpec::new("sac", 1, None).write(root);
    incomplete(&live);
    let lock = DirLock::try_acquire(&live).unwrap();
    // Running too: a complete summary.json, but a process is rewriting the directory (a budget
    // being extended).
    let extending = RunSpec::new("sac", 2, None).write(root);
    let extending_lock = DirLock::try_acquire(&extending).unwrap();
    // Stopped: incomplete, with a checkpoint; and one whose checkpoint was left as
    // `checkpoint.old` by an interrupted replacement (what --resume resumes from).
    let stopped = RunSpec::new("sac", 3, None).write(root);
    incomplete(&stopped);
    std::fs::create_dir_all(stopped.join("checkpoint/agent")).unwrap();
    let stopped_old = RunSpec::new("sac", 4, None).write(root);
    std::fs::remove_file(stopped_old.join("summary.json")).unwrap();
    std::fs::create_dir_all(stopped_old.join("checkpoint.old")).unwrap();
    // Broken: no summary.json, no checkpoint, a config.toml to start again from.
    let died = RunSpec::new("sac", 5, None).write(root);
    std::fs::remove_file(died.join("summary.json")).unwrap();
    // Broken: nothing but a lock file nobody holds (a run killed before writing config.toml).
    let empty = root.join("killed-at-start");
    std::fs::create_dir_all(&empty).unwrap();
    drop(DirLock::try_acquire(&empty).unwrap());

    let set = load_runs(&[root]).unwrap();
    assert_eq!(set.runs.iter().map(|r| r.dir.clone()).collect::<Vec<_>>(), vec![complete]);
    assert_eq!(set.skipped.len(), 6, "{:?}", set.skipped);
    let pid = std::process::id();

    let s = one(&set.skipped, &live);
    assert_eq!(s.kind, SkipKind::Running);
    assert_eq!(s.reason, format!("still running (its lock .lock is held by pid {pid})"));
    assert_eq!(one(&set.skipped, &extending).kind, SkipKind::Running);

    let s = one(&set.skipped, &stopped);
    assert_eq!(s.kind, SkipKind::Stopped);
    assert_eq!(
        s.reason,
        format!(
            "stopped (summary.json says \"complete\": false; a checkpoint is present: `defender train --out {} \
             --resume` continues it)",
            stopped.display()
        )
    );
    let s = one(&set.skipped, &stopped_old);
    assert_eq!(s.kind, SkipKind::Stopped);
    assert!(s.reason.starts_with("stopped (no summary.json; a checkpoint is present"), "{}", s.reason);

    let s = one(&set.skipped, &died);
    assert_eq!(s.kind, SkipKind::Broken);
    assert!(
        s.reason.starts_with("broken (no summary.json, no process holds its lock and there is no checkpoint")
    );
    assert!(s.reason.ends_with("starts it again from its config.toml)"), "{}", s.reason);
    let s = one(&set.skipped, &empty);
    assert_eq!(s.kind, SkipKind::Broken);
    assert!(s.reason.contains("no config.toml") && s.reason.ends_with("nothing to resume)"), "{}", s.reason);

    // The lock released (the run ended or was killed): no longer running.
    drop(lock);
    drop(extending_lock);
    let skipped = skipped_of(root);
    assert_eq!(one(&skipped, &live).kind, SkipKind::Broken);
    assert!(skipped.iter().all(|s| s.dir != extending), "complete and unlocked: reported");
}

#[test]
fn a_sweep_directory_is_searched_but_is_not_a_run() {
    let root = tempfile::tempdir().unwrap();
    // As `defender sweep --out sweep` lays it out: its own lock and `.sweep/` beside the task
    // folders.
    let sweep = root.path().join("sweep");
    let run = RunSpec::new("sac", 0, A).write(&sweep.join("Hopper-v5"));
    std::fs::create_dir_all(sweep.join(".sweep/configs")).unwrap();
    std::fs::write(sweep.join(".sweep/configs/config.toml"), "not a run").unwrap();
    let _lock = DirLock::try_acquire(&sweep).unwrap();
    assert_eq!(find_run_dirs(&[&sweep]).unwrap(), vec![run]);
    let set = load_runs(&[&sweep]).unwrap();
    assert_eq!((set.runs.len(), set.skipped.len()), (1, 0));
}

/// An experiment shares another's run of the same configuration by a symbolic link to it: the
/// link is found as a run of the folder it sits in, and a run reached both ways counts once.
#[test]
fn a_linked_run_directory_is_found_and_counted_once() {
    let root = tempfile::tempdir().unwrap();
    let screen = root.path().join("screen");
    let shared = RunSpec::new("sac", 0, A).write(&screen.join("Hopper-v5"));
    let finals = root.path().join("finals");
    let own = RunSpec::new("sac", 2, A).write(&finals.join("Hopper-v5"));
    let link = finals.join("Hopper-v5").join(shared.file_name().unwrap());
    std::os::unix::fs::symlink(&shared, &link).unwrap();

    assert_eq!(find_run_dirs(&[&finals]).unwrap(), vec![link.clone(), own.clone()]);
    assert_eq!(load_runs(&[&finals]).unwrap().runs.len(), 2);
    // Both folders named: the linked run once (by its first path), not twice.
    assert_eq!(find_run_dirs(&[&finals, &screen]).unwrap().len(), 2);
}
