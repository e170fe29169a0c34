//! The random walks of the DTW benchmark and of `examples/dtw_speed.rs` (included by both with
//! `#[path]`), so that both time the same data.

/// A random walk, like a trajectory (fixed LCG, no dependency).
pub fn walk(len: usize, dim: usize, seed: u64) -> Vec<f32> {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    let mut pos = vec![0.0f32; dim];
    let mut out = Vec::with_capacity(len * dim);
    for _ in 0..len {
        for p in &mut pos {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            *p += ((state >> 40) as f32 / (1u64 << 24) as f32) - 0.5;
            out.push(*p);
        }
    }
    out
}
