//! Forward + backward of a 256-wide MLP at batch 256, and a SAC-shaped update.
//!
//! `cargo bench -p defender-nn --bench mlp`; figures go to docs/benchmarks-core.md. Throughput is
//! in FLOP (2 per multiply-add), so "Gelem/s" reads as GFLOP/s.
#![allow(missing_docs)]

#[path = "common/sac_shape.rs"]
mod sac_shape;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use defender_nn::faer::Mat;
use defender_nn::{Activation, Mlp, Parallelism};
use rand::SeedableRng;
use sac_shape::{BATCH, SacShape, macs};

fn settings() -> [(&'static str, Parallelism); 2] {
    [("1thread", Parallelism::Sequential), ("2threads", Parallelism::threads(2))]
}

fn fwd_bwd(c: &mut Criterion) {
    let widths = [256, 256, 256, 256];
    let mut group = c.benchmark_group("mlp_256x3_b256");
    // Forward 1 GEMM per layer, backward 2 (parameters and input).
    group.throughput(Throughput::Elements(2 * 3 * macs(&widths, BATCH)));
    for (name, par) in settings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut mlp =
            Mlp::new(&widths, Activation::Relu, Activation::Identity, &mut rng).with_parallelism(par);
        let x = Mat::<f32>::from_fn(BATCH, 256, |i, j| ((i * 3 + j) % 17) as f32 / 17.0 - 0.5);
        let g = Mat::<f32>::from_fn(BATCH, 256, |i, j| ((i + 5 * j) % 13) as f32 / 13.0 - 0.5);
        group.bench_function(format!("fwd_bwd/{name}"), |bench| {
            bench.iter(|| {
                mlp.forward(x.as_ref());
                mlp.backward(g.as_ref());
            })
        });
    }
    group.finish();
}

/// Two critics, their targets and the actor on Hopper: see `common/sac_shape.rs`.
fn sac_update(c: &mut Criterion) {
    let mut group = c.benchmark_group("sac_shaped_update_hopper");
    group.throughput(Throughput::Elements(SacShape::flops()));
    for (name, par) in settings() {
        let mut sac = SacShape::new(par);
        group.bench_function(format!("update/{name}"), |bench| bench.iter(|| sac.update()));
    }
    group.finish();
}

criterion_group!(benches, fwd_bwd, sac_update);
criterion_main!(benches);
