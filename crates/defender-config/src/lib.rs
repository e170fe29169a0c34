//! What a user configures, read and checked before anything runs: a run's configuration
//! (`config.toml`, `defender train --config`), the profiles that fill it, experiment files and
//! their expansion into runs, the warnings for settings that would do nothing, and which changes
//! a resumed run may make. Every bad value is refused here with the section, key and value to fix.
//!
//! No simulator is linked: the fuzz targets (`fuzz/`) call these parsers directly.

pub mod experiment;
pub mod inert;
pub mod profile;
pub mod resume;
pub mod run_config;
mod shipped;

pub use shipped::shipped_demos;
