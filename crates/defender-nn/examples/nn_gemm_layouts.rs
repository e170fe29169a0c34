//! Times the GEMM orientations an MLP layer uses (256^3 f32), one and two threads: the
//! evidence for the crate's layout choice. `cargo run --release -p defender-nn --example
//! nn_gemm_layouts`. Reports the best of many repetitions (the machine is shared).

use std::hint::black_box;
use std::num::NonZeroUsize;
use std::time::Instant;

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn main() {
    let n = 256;
    let a = Mat::<f32>::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f32 * 0.1);
    let b = Mat::<f32>::from_fn(n, n, |i, j| ((i * 5 + j) % 13) as f32 * 0.1);
    let mut c = Mat::<f32>::zeros(n, n);
    let flops = 2.0 * (n * n * n) as f64;
    let two = NonZeroUsize::new(2).map(Par::Rayon).unwrap_or(Par::Seq);
    for (pname, par) in [("1 thread", Par::Seq), ("2 threads", two)] {
        for (name, ta, tb) in
            [("A B", false, false), ("A^T B", true, false), ("A B^T", false, true), ("A^T B^T", true, true)]
        {
            let t = best_of(200, || {
                let lhs = if ta { a.transpose() } else { a.as_ref() };
                let rhs = if tb { b.transpose() } else { b.as_ref() };
                matmul(c.as_mut(), Accum::Replace, lhs, rhs, 1.0, par);
                black_box(&c);
            });
            println!("{pname:9} {name:8} {:6.1} us {:6.1} GFLOP/s", t * 1e6, flops / t / 1e9);
        }
    }
}
