//! `cargo +nightly fuzz run experiment`: see `defender_fuzz::experiment` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::experiment(data);
});
