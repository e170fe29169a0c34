//! `cargo +nightly fuzz run strategy`: see `defender_fuzz::strategy` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::strategy(data);
});
