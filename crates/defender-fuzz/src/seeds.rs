//! Seeds that are built rather than written by hand: files with checksums and binary arrays.
//! `cargo run --release -p defender-fuzz --example write_seeds` writes them into
//! `fuzz/corpus/<target>/`, where they are committed with the hand-written ones.

use crate::files::{stored_zip, valid_arrays};

/// `(file name, bytes)` seeds of `target` (none for the text formats, whose seeds are written by
/// hand).
pub fn built(target: &str) -> Vec<(String, Vec<u8>)> {
    match target {
        "episode_set" => vec![("valid.npz".into(), stored_zip(&valid_arrays()))],
        "npy_arrays" => valid_arrays()
            .into_iter()
            .enumerate()
            .map(|(i, (name, bytes))| {
                let mut v = vec![i as u8];
                v.extend_from_slice(&bytes);
                (format!("{i}-{name}"), v)
            })
            .collect(),
        "checkpoint" => {
            crate::checkpoint::seeds().into_iter().map(|v| (format!("file-{}", v[0]), v)).collect()
        }
        _ => Vec::new(),
    }
}
