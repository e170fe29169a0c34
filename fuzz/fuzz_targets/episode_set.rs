//! `cargo +nightly fuzz run episode_set`: see `defender_fuzz::episode_set` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::episode_set(data);
});
