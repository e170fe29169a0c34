//! Steady-state passes allocate nothing: a counting global allocator around forward,
//! backward (all three kinds), Adam, Polyak and the loss, after one warm-up update, with
//! batch sizes alternating between acting (1) and updating (256).

#![allow(clippy::unwrap_used)] // tests may unwrap (helpers are outside #[test] fns)

use defender_nn::faer::Mat;
use defender_nn::{Activation, Adam, AdamConfig, Mlp, Parallelism, mse_loss_grad};
use rand::SeedableRng;

#[global_allocator]
static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;

fn update(
    q: &mut Mlp,
    q_target: &mut Mlp,
    opt: &mut Adam,
    x: &Mat<f32>,
    one: &Mat<f32>,
    y: &Mat<f32>,
    g: &mut Mat<f32>,
) {
    q.forward(one.as_ref()); // acting: batch 1
    let out = q.forward(x.as_ref());
    mse_loss_grad(out, y.as_ref(), g.as_mut());
    q.zero_grad();
    q.backward(g.as_ref());
    q.backward_params(g.as_ref());
    opt.step(q);
    q.forward(x.as_ref());
    q.backward_input(g.as_ref());
    q_target.polyak_update(q, 0.005);
}

#[test]
fn steady_state_updates_do_not_allocate() {
    // Sequential: with GEMMs split over rayon threads, faer's parallel GEMM and rayon's job
    // queue allocate small objects per call (~120 per update of this critic, measured),
    // outside this crate's buffers.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let mut q = Mlp::new(&[14, 256, 256, 1], Activation::Relu, Activation::Identity, &mut rng)
        .with_parallelism(Parallelism::Sequential);
    let mut q_target = q.clone();
    let mut opt = Adam::new(&q, AdamConfig::default());
    let x = Mat::<f32>::from_fn(256, 14, |i, j| ((i + j) % 5) as f32 * 0.2);
    let one = Mat::<f32>::from_fn(1, 14, |_, j| j as f32 * 0.1);
    let y = Mat::<f32>::zeros(256, 1);
    let mut g = Mat::<f32>::zeros(256, 1);
    update(&mut q, &mut q_target, &mut opt, &x, &one, &y, &mut g);
    let before = alloc_counter::allocations();
    for _ in 0..3 {
        update(&mut q, &mut q_target, &mut opt, &x, &one, &y, &mut g);
    }
    let after = alloc_counter::allocations();
    assert_eq!(after - before, 0, "allocations in 3 steady-state updates");
}
