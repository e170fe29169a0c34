//! `cargo +nightly fuzz run run_directory`: see `defender_fuzz::run_directory` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::run_directory(data);
});
