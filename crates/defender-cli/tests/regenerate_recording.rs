//! `tools/golden/regenerate-recording.sh` (the screens read recordings that git ignores): it
//! trains a run's configuration again and regenerates its recording bit for bit, and says so
//! only when the new run's episodes equal the committed run's.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

mod common;

use common::{ok, s};

fn regenerate(run: &Path, steps: &str, out: &Path) -> std::process::Output {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/golden/regenerate-recording.sh");
    Command::new("bash")
        .arg(script)
        .args([s(run), steps, s(out)])
        .env("DEFENDER", env!("CARGO_BIN_EXE_defender"))
        .env("DEFENDER_NN_THREADS", "1")
        .output()
        .unwrap()
}

#[test]
fn a_recording_is_regenerated_bit_for_bit_from_its_committed_run() {
    let root = tempfile::tempdir().unwrap();
    let (run, npz) = (root.path().join("run"), root.path().join("episodes.npz"));
    let args = ["train", "--env", "InvertedDoublePendulum-v5", "--steps", "600", "--seed", "4"];
    ok(&[&args[..], &["--record-episodes", s(&npz), "--out", s(&run)]].concat());
    // The whole budget: the same bytes.
    let out = regenerate(&run, "600", &root.path().join("full"));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.contains("equal the committed run's"), "{said}");
    assert_eq!(std::fs::read(root.path().join("full/episodes.npz")).unwrap(), std::fs::read(&npz).unwrap());
    // A run whose committed metrics were changed is not the run it claims: refused.
    let metrics = run.join("metrics.csv");
    let text = std::fs::read_to_string(&metrics).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[2] = lines[2].replacen(',', ",9", 2);
    std::fs::write(&metrics, lines.join("\n") + "\n").unwrap();
    let out = regenerate(&run, "300", &root.path().join("part"));
    assert!(!out.status.success(), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(String::from_utf8_lossy(&out.stderr).contains("differs"));
}
