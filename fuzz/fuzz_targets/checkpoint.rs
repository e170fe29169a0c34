//! `cargo +nightly fuzz run checkpoint`: see `defender_fuzz::checkpoint` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::checkpoint(data);
});
