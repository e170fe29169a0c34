//! The naive O(nm) DTW every fast path is checked against (SPEC section 2), in f64.
#![allow(dead_code)]

#[allow(unused_imports)] // each test file uses a part
pub use defender_dtw::oracle::naive_dtw;

/// `got` (f32) equals `want` up to f32 rounding along a path of up to a few thousand cells.
pub fn close(got: f32, want: f64) -> bool {
    if want.is_infinite() {
        return got == f32::INFINITY;
    }
    (f64::from(got) - want).abs() <= 1e-5 * want.abs().max(1.0)
}

/// The last `k` elements of a row-major sequence.
pub fn last(v: &[f32], dim: usize, k: usize) -> &[f32] {
    let len = v.len() / dim;
    &v[(len - k.min(len)) * dim..]
}
