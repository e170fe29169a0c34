//! Forward + backward of 256-wide MLPs at batch 256, and a SAC-shaped update.
//!
//! `cargo bench -p defender-nn --bench mlp`; figures go to docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use defender_nn::faer::Mat;
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand::SeedableRng;

const BATCH: usize = 256;

fn input(rows: usize, cols: usize) -> Mat<f32> {
    Mat::from_fn(rows, cols, |i, j| (((i * 31 + j * 17) % 29) as f32 - 14.0) / 14.0)
}

/// Multiply-adds of one forward pass of `widths` at batch `b`.
fn macs(widths: &[usize], b: usize) -> u64 {
    widths.windows(2).map(|w| (w[0] * w[1] * b) as u64).sum()
}

fn settings() -> [(&'static str, Parallelism); 2] {
    [("1thread", Parallelism::Sequential), ("2threads", Parallelism::threads(2))]
}

fn fwd_bwd(c: &mut Criterion) {
    let widths = [256, 256, 256, 256];
    let mut group = c.benchmark_group("mlp_256x3_b256");
    // forward 1x, backward 2x (params + input): 3 GEMMs per layer, 2 flops per MAC.
    group.throughput(Throughput::Elements(6 * macs(&widths, BATCH)));
    for (name, par) in settings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut mlp =
            Mlp::new(&widths, Activation::Relu, Activation::Identity, &mut rng).with_parallelism(par);
        let x = input(BATCH, 256);
        let g = input(BATCH, 256);
        group.bench_function(format!("fwd_bwd/{name}"), |bench| {
            bench.iter(|| {
                mlp.forward(x.as_ref());
                mlp.backward(g.as_ref());
            })
        });
    }
    group.finish();
}

/// The GEMM work of one SAC update on Hopper (obs 11, act 3, 256x256 nets): critic forward and
/// backward for two critics, target critics and the actor on next_obs, the actor's forward and
/// backward through both critics, Adam on all three, Polyak on the critics.
fn sac_update(c: &mut Criterion) {
    let (obs, act) = (11, 3);
    let mut group = c.benchmark_group("sac_shaped_update_hopper");
    let q_w = [obs + act, 256, 256, 1];
    let pi_w = [obs, 256, 256, 2 * act];
    let flops = 2
        * (2 * macs(&q_w, BATCH) // target critics
            + macs(&pi_w, BATCH) // actor on next_obs
            + 2 * 3 * macs(&q_w, BATCH) // critics fwd + bwd
            + 2 * 2 * macs(&q_w, BATCH) // critics fwd + input-bwd for the actor loss
            + 3 * macs(&pi_w, BATCH)); // actor fwd + bwd
    group.throughput(Throughput::Elements(flops));
    for (name, par) in settings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut new = |w: &[usize], out| Mlp::new(w, Activation::Relu, out, &mut rng).with_parallelism(par);
        let mut q1 = new(&q_w, Activation::Identity);
        let mut q2 = new(&q_w, Activation::Identity);
        let mut pi = new(&pi_w, Activation::Identity);
        let mut q1_t = q1.clone();
        let mut q2_t = q2.clone();
        let cfg = AdamConfig { lr: 3e-4, ..Default::default() };
        let (mut o1, mut o2, mut op) = (Adam::new(&q1, cfg), Adam::new(&q2, cfg), Adam::new(&pi, cfg));
        let s = input(BATCH, obs);
        let mut sa = input(BATCH, obs + act);
        let g_q = input(BATCH, 1);
        let g_pi = input(BATCH, 2 * act);
        group.bench_function(format!("update/{name}"), |bench| {
            bench.iter(|| {
                // Targets.
                let a_next = pi.forward(s.as_ref());
                for j in 0..act {
                    for i in 0..BATCH {
                        sa[(i, obs + j)] = a_next[(i, j)].tanh();
                    }
                }
                q1_t.forward(sa.as_ref());
                q2_t.forward(sa.as_ref());
                // Critic losses.
                for (q, o) in [(&mut q1, &mut o1), (&mut q2, &mut o2)] {
                    q.forward(sa.as_ref());
                    q.zero_grad();
                    q.backward_params(g_q.as_ref());
                    o.step(q);
                }
                // Actor loss through the critics.
                pi.forward(s.as_ref());
                q1.forward(sa.as_ref());
                q1.backward_input(g_q.as_ref());
                q2.forward(sa.as_ref());
                q2.backward_input(g_q.as_ref());
                pi.zero_grad();
                pi.backward_params(g_pi.as_ref());
                op.step(&mut pi);
                q1_t.polyak_update(&q1, 0.005);
                q2_t.polyak_update(&q2, 0.005);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, fwd_bwd, sac_update);
criterion_main!(benches);
