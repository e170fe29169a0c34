//! Episode-set files (`.npz`: the zip container, the `.npy` headers and data, the `meta` JSON).

use crate::files::{stored_zip, valid_arrays};
use crate::scratch;

/// A whole `.npz` file, as `EpisodeSet::load` reads it from disk.
pub fn episode_set(data: &[u8]) -> bool {
    let path = scratch::thread_path("set.npz");
    if std::fs::write(&path, data).is_err() {
        return false;
    }
    defender::EpisodeSet::load(&path).is_ok()
}

/// One array of an otherwise valid episode set, picked by the first byte (`obs`, `act`, `rew`,
/// `ep_len`, `crashed`, `meta`), the rest its `.npy` file, in a zip whose CRCs are right: every
/// mutation reaches the `.npy` header, data and `meta` JSON parsers.
pub fn npy_arrays(data: &[u8]) -> bool {
    let Some((&which, bytes)) = data.split_first() else { return false };
    let mut arrays = valid_arrays();
    let which = usize::from(which) % arrays.len();
    arrays[which].1 = bytes.to_vec();
    episode_set(&stored_zip(&arrays))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_valid_set_is_accepted_and_a_truncated_one_refused() {
        let valid = stored_zip(&valid_arrays());
        assert!(episode_set(&valid));
        assert!(!episode_set(&valid[..valid.len() / 2]));
        let mut obs = vec![0u8];
        obs.extend_from_slice(&valid_arrays()[0].1);
        assert!(npy_arrays(&obs));
        obs.truncate(obs.len() - 1);
        assert!(!npy_arrays(&obs));
    }
}
