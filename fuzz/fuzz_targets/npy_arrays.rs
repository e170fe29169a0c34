//! `cargo +nightly fuzz run npy_arrays`: see `defender_fuzz::npy_arrays` and docs/fuzzing.md.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    defender_fuzz::npy_arrays(data);
});
