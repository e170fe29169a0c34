//! The default of `[defender] demos` (and of a bare run's `demos`): the demonstration set shipped
//! for the task.

use std::path::PathBuf;

/// Where the demonstration set shipped for `env_id` lives: `$DEFENDER_DATA/demos/<ENV>.npz`,
/// else `data/demos/<ENV>.npz` in the source tree the binary was built from (named at build time
/// by `DEFENDER_SHIPPED_DATA`, `.cargo/config.toml`; the wheel's build leaves it empty so that an
/// installed binary never reaches for a source tree). `None` when neither is known.
pub fn shipped_demos(env_id: &str) -> Option<PathBuf> {
    let data = std::env::var_os("DEFENDER_DATA")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| option_env!("DEFENDER_SHIPPED_DATA").filter(|d| !d.is_empty()).map(PathBuf::from))?;
    // Canonical when it exists, so that config.toml records a readable path.
    let data = data.canonicalize().unwrap_or(data);
    Some(data.join("demos").join(format!("{env_id}.npz")))
}
