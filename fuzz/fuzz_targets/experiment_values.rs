//! `cargo +nightly fuzz run experiment_values`: see `defender_fuzz::experiment_values` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::experiment_values(data);
});
