//! `cargo +nightly fuzz run config`: see `defender_fuzz::config` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::config(data);
});
