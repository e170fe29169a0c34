//! Best-of-N timings of the pieces of an MLP update (forward, backward variants, Adam,
//! Polyak) for a Hopper-sized critic, one and two threads. `cargo run --release -p
//! defender-nn --example nn_profile`. Best-of timings resist a shared machine's noise.

#[path = "../benches/common/sac_shape.rs"]
#[allow(dead_code)]
mod sac_shape;

use std::hint::black_box;
use std::time::Instant;

use defender_nn::faer::Mat;
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism};
use rand::SeedableRng;

fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best * 1e6
}

fn main() {
    for par in [Parallelism::Sequential, Parallelism::threads(2)] {
        let mut sac = sac_shape::SacShape::new(par);
        let us = best_of(100, || sac.update());
        println!(
            "SAC-shaped update (Hopper, batch 256) {} thr: {us:.0} us ({:.0} GFLOP/s)",
            par.num_threads(),
            sac_shape::SacShape::flops() as f64 / us / 1e3
        );
    }
    {
        // Acting: the actor at batch 1, every environment step.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut pi = Mlp::new(&[11, 256, 256, 6], Activation::Relu, Activation::Identity, &mut rng);
        let s = Mat::<f32>::from_fn(1, 11, |_, j| j as f32 * 0.1);
        let us = best_of(1000, || {
            black_box(pi.forward(s.as_ref()));
        });
        println!("actor 11-256-256-6 forward at batch 1: {us:.1} us");
    }
    let b = 256;
    for widths in [vec![14, 256, 256, 1], vec![256, 256, 256, 256]] {
        let macs: usize = widths.windows(2).map(|w| w[0] * w[1] * b).sum();
        for par in [Parallelism::Sequential, Parallelism::threads(2)] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
            let mut q =
                Mlp::new(&widths, Activation::Relu, Activation::Identity, &mut rng).with_parallelism(par);
            let t = q.clone();
            let x = Mat::<f32>::from_fn(b, widths[0], |i, j| ((i + 3 * j) % 7) as f32 * 0.1 - 0.3);
            let g = Mat::<f32>::from_fn(b, *widths.last().unwrap_or(&1), |i, _| (i % 5) as f32 * 0.01);
            let mut opt = Adam::new(&q, AdamConfig::default());
            let mut tgt = t.clone();
            let fwd = best_of(300, || {
                black_box(q.forward(x.as_ref()));
            });
            let bwd = best_of(300, || {
                black_box(q.backward(g.as_ref()));
            });
            let bwd_in = best_of(300, || {
                black_box(q.backward_input(g.as_ref()));
            });
            let bwd_p = best_of(300, || q.backward_params(g.as_ref()));
            let adam = best_of(300, || opt.step(&mut q));
            let polyak = best_of(300, || tgt.polyak_update(&q, 0.005));
            let gf = |us: f64, gemms: usize| (2 * gemms * macs) as f64 / us / 1e3;
            println!(
                "{widths:?} {} thr: fwd {fwd:.0} us ({:.0} GFLOP/s), bwd {bwd:.0} us ({:.0}), bwd_input {bwd_in:.0} us, \
                 bwd_params {bwd_p:.0} us, adam {adam:.0} us, polyak {polyak:.0} us",
                par.num_threads(),
                gf(fwd, 1),
                gf(bwd, 2)
            );
        }
    }
}
