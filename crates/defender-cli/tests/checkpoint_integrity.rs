//! Checkpoint integrity through the binary: a one-bit flip in any file of a checkpoint (networks,
//! targets, optimiser state, replay buffer, RNG/JSON state, DEFENDER's dynamics model, the pinned
//! configuration) makes `defender train --resume` fail, naming the file, instead of resuming a
//! silently different run. A checkpoint without a manifest (an older version's) resumes with a
//! warning.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

mod common;

use common::{defender, s, text};

const ENV_ID: &str = "InvertedDoublePendulum-v5";

/// Every file of the checkpoint but the manifest, relative and `/`-separated.
fn files(root: &Path, dir: &Path, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files(root, &path, out);
        } else {
            let rel = path.strip_prefix(root).unwrap().to_str().unwrap().replace('\\', "/");
            if rel != "manifest.json" {
                out.push(rel);
            }
        }
    }
}

fn flip_bit(path: &Path) -> Vec<u8> {
    let original = std::fs::read(path).unwrap();
    let mut bytes = original.clone();
    assert!(!bytes.is_empty(), "{}: empty", path.display());
    let i = bytes.len() / 2;
    bytes[i] ^= 0x10;
    std::fs::write(path, &bytes).unwrap();
    original
}

#[test]
fn a_flipped_bit_in_any_checkpoint_file_is_refused_naming_the_file() {
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("run");
    let episodes = root.path().join("episodes.npz");
    let args = [
        "train",
        "--env",
        ENV_ID,
        "--algo",
        "sac",
        "--strategy",
        "MinDemoW5/MinDemoW10",
        "--steps",
        "300",
        "--seed",
        "1",
        "--out",
        s(&out),
        "--record-episodes",
        s(&episodes),
    ];
    let first = defender(&args);
    assert!(first.status.success(), "train failed:\n{}", text(&first));
    let dynamics = std::fs::read_to_string(out.join("dynamics.csv")).unwrap();
    assert!(dynamics.starts_with("total_steps,real_steps,gradient_steps,"), "{dynamics}");
    let checkpoint = out.join("checkpoint");
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(checkpoint.join("manifest.json")).unwrap()).unwrap();
    let mut names = Vec::new();
    files(&checkpoint, &checkpoint, &mut names);
    names.sort();
    for name in &names {
        assert!(manifest["files"][name].is_object(), "{name} is not in the manifest: {manifest}");
    }
    // Each kind of file a checkpoint holds is there to be tested.
    for kind in [
        "actor.safetensors",
        "target.safetensors",
        ".adam.safetensors",
        "replay.bin",
        "state.json",
        "trainer.json",
        "env/dynamics/dynamics.safetensors",
        "env/dynamics/dynamics_adam.safetensors",
        "env/dynamics/dynamics_buffer.bin",
        "env/dynamics/dynamics_state.json",
        "env/defender_stats.json",
        "extra/",
    ] {
        assert!(names.iter().any(|n| n.contains(kind)), "no checkpoint file like {kind}: {names:?}");
    }
    let resume = ["train", "--out", s(&out), "--resume"];
    for name in &names {
        let path = checkpoint.join(name);
        let original = flip_bit(&path);
        let run = defender(&resume);
        std::fs::write(&path, original).unwrap();
        let msg = text(&run);
        assert!(!run.status.success(), "{name}: a flipped bit was resumed:\n{msg}");
        assert_eq!(run.status.code(), Some(1), "{name}: {msg}");
        assert!(msg.contains(name.as_str()), "{name}: the error should name the file:\n{msg}");
        assert!(msg.contains("checksum mismatch (the file is corrupt)"), "{name}:\n{msg}");
        assert!(!msg.contains("panicked"), "{name}:\n{msg}");
    }
    // A corrupt manifest is refused too (whatever it now says).
    let original = flip_bit(&checkpoint.join("manifest.json"));
    let run = defender(&resume);
    std::fs::write(checkpoint.join("manifest.json"), &original).unwrap();
    assert_eq!(run.status.code(), Some(1), "a corrupt manifest was resumed:\n{}", text(&run));
    // Intact, it resumes (the run is complete: nothing more to train).
    std::fs::write(checkpoint.join("manifest.json"), &original).unwrap();
    let run = defender(&resume);
    assert!(run.status.success(), "the intact checkpoint was refused:\n{}", text(&run));
    // A checkpoint without a manifest (an older version's) resumes with a warning saying why,
    // so that a run begun with an older version is not lost.
    std::fs::remove_file(checkpoint.join("manifest.json")).unwrap();
    let run = defender(&resume);
    let msg = text(&run);
    assert!(run.status.success(), "{msg}");
    assert!(
        msg.contains("warning") && msg.contains("no manifest.json") && msg.contains("older defender"),
        "{msg}"
    );
}
