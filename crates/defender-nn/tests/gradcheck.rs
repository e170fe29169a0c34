//! Finite-difference gradient checks: the analytic f32 forward/backward against an independent
//! f64 reference MLP differentiated by central differences, for every activation in every
//! position, parameter and input gradients; and the MSE loss's gradient.

#![allow(clippy::unwrap_used)] // tests may unwrap (helpers are outside #[test] fns)

use defender_nn::faer::Mat;
use defender_nn::{Activation, Mlp, Parallelism, mse_loss, mse_loss_grad};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const ACTS: [Activation; 4] = [Activation::Identity, Activation::Relu, Activation::Tanh, Activation::Sigmoid];

fn act64(a: Activation, x: f64) -> f64 {
    match a {
        Activation::Identity => x,
        Activation::Relu => x.max(0.0),
        Activation::Tanh => x.tanh(),
        Activation::Sigmoid => 1.0 / (1.0 + (-x).exp()),
    }
}

/// Reference forward in f64 from a flat parameter vector laid out as `Mlp::params`
/// (per layer: `[out, in]` row-major weight, then bias). `x` is `batch x in` row-major.
fn reference_forward(
    widths: &[usize],
    hidden: Activation,
    output: Activation,
    p: &[f64],
    x: &[f64],
) -> Vec<f64> {
    let batch = x.len() / widths[0];
    let mut cur = x.to_vec();
    let mut off = 0;
    for (l, w) in widths.windows(2).enumerate() {
        let (n_in, n_out) = (w[0], w[1]);
        let (wt, b) = (&p[off..off + n_in * n_out], &p[off + n_in * n_out..off + n_in * n_out + n_out]);
        off += n_in * n_out + n_out;
        let act = if l == widths.len() - 2 { output } else { hidden };
        let mut next = vec![0.0; batch * n_out];
        for s in 0..batch {
            for o in 0..n_out {
                let z: f64 = b[o] + (0..n_in).map(|i| wt[o * n_in + i] * cur[s * n_in + i]).sum::<f64>();
                next[s * n_out + o] = act64(act, z);
            }
        }
        cur = next;
    }
    cur
}

/// `L = sum(out * r)`, so `dL/dout = r`.
fn reference_loss(widths: &[usize], h: Activation, o: Activation, p: &[f64], x: &[f64], r: &[f64]) -> f64 {
    reference_forward(widths, h, o, p, x).iter().zip(r).map(|(a, b)| a * b).sum()
}

fn close(analytic: f32, numeric: f64, what: &str) {
    let tol = 2e-4 + 2e-3 * numeric.abs();
    assert!(
        (analytic as f64 - numeric).abs() <= tol,
        "{what}: analytic {analytic} vs finite difference {numeric}"
    );
}

fn check_network(widths: &[usize], hidden: Activation, output: Activation, batch: usize, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut mlp = Mlp::new(widths, hidden, output, &mut rng);
    // Inputs and biases away from ReLU's kink at the finite-difference scale.
    let x = Mat::<f32>::from_fn(batch, widths[0], |_, _| rng.random_range(-2.0..2.0));
    let r = Mat::<f32>::from_fn(batch, *widths.last().unwrap(), |_, _| rng.random_range(-1.0..1.0));
    let p64: Vec<f64> = mlp.params().iter().map(|&v| v as f64).collect();
    let x64: Vec<f64> =
        (0..batch).flat_map(|i| (0..widths[0]).map(move |j| (i, j))).map(|(i, j)| x[(i, j)] as f64).collect();
    let r64: Vec<f64> =
        (0..batch).flat_map(|i| (0..r.ncols()).map(move |j| (i, j))).map(|(i, j)| r[(i, j)] as f64).collect();

    let out = mlp.forward(x.as_ref()).to_owned();
    let out_ref = reference_forward(widths, hidden, output, &p64, &x64);
    for i in 0..batch {
        for j in 0..out.ncols() {
            close(out[(i, j)], out_ref[i * out.ncols() + j], &format!("output ({i},{j})"));
        }
    }
    mlp.zero_grad();
    let grad_in = mlp.backward(r.as_ref()).to_owned();

    let h = 1e-6;
    let fd = |p: &[f64], x: &[f64]| reference_loss(widths, hidden, output, p, x, &r64);
    for k in 0..p64.len() {
        let (mut plus, mut minus) = (p64.clone(), p64.clone());
        plus[k] += h;
        minus[k] -= h;
        let numeric = (fd(&plus, &x64) - fd(&minus, &x64)) / (2.0 * h);
        close(mlp.grads()[k], numeric, &format!("{hidden:?}/{output:?} param {k}"));
    }
    for k in 0..x64.len() {
        let (mut plus, mut minus) = (x64.clone(), x64.clone());
        plus[k] += h;
        minus[k] -= h;
        let numeric = (fd(&p64, &plus) - fd(&p64, &minus)) / (2.0 * h);
        let (i, j) = (k / widths[0], k % widths[0]);
        close(grad_in[(i, j)], numeric, &format!("{hidden:?}/{output:?} input ({i},{j})"));
    }
}

#[test]
fn every_activation_in_every_position_matches_finite_differences() {
    for (a, &hidden) in ACTS.iter().enumerate() {
        for (b, &output) in ACTS.iter().enumerate() {
            check_network(&[5, 7, 6, 3], hidden, output, 4, (10 * a + b) as u64);
        }
    }
}

#[test]
fn single_linear_layer_and_deep_narrow_network() {
    check_network(&[4, 3], Activation::Identity, Activation::Identity, 3, 1);
    check_network(&[2, 3, 1, 4, 1, 2], Activation::Tanh, Activation::Relu, 5, 2);
    check_network(&[6, 1], Activation::Relu, Activation::Tanh, 1, 3);
}

#[test]
fn input_only_and_params_only_backward_agree_with_full_backward() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut mlp = Mlp::new(&[6, 16, 16, 2], Activation::Relu, Activation::Identity, &mut rng);
    let x = Mat::<f32>::from_fn(9, 6, |_, _| rng.random_range(-1.0..1.0));
    let g = Mat::<f32>::from_fn(9, 2, |_, _| rng.random_range(-1.0..1.0));
    mlp.forward(x.as_ref());
    mlp.zero_grad();
    let full_in = mlp.backward(g.as_ref()).to_owned();
    let full_grads = mlp.grads().to_vec();

    // Input only: same input gradient, parameter gradients untouched (still the full ones).
    mlp.forward(x.as_ref());
    let in_only = mlp.backward_input(g.as_ref()).to_owned();
    assert_eq!(in_only, full_in);
    assert_eq!(mlp.grads(), full_grads.as_slice());

    // Params only after zero_grad: the same parameter gradients.
    mlp.zero_grad();
    mlp.backward_params(g.as_ref());
    assert_eq!(mlp.grads(), full_grads.as_slice());

    // Gradients accumulate until zero_grad.
    mlp.backward(g.as_ref());
    for (a, b) in mlp.grads().iter().zip(&full_grads) {
        assert!((a - 2.0 * b).abs() <= 1e-6 * (1.0 + b.abs()));
    }
}

#[test]
fn threads_do_not_change_results_and_batches_reuse_buffers() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut seq = Mlp::new(&[14, 256, 256, 1], Activation::Relu, Activation::Identity, &mut rng)
        .with_parallelism(Parallelism::Sequential);
    let mut par = seq.clone().with_parallelism(Parallelism::threads(2));
    let x = Mat::<f32>::from_fn(256, 14, |_, _| rng.random_range(-1.0..1.0));
    let g = Mat::<f32>::from_fn(256, 1, |_, _| rng.random_range(-1.0..1.0));
    let gemms = defender_nn::parallel_gemms_on_this_thread;
    let before = gemms();
    let out_seq = seq.forward(x.as_ref()).to_owned();
    let gi_seq = seq.backward(g.as_ref()).to_owned();
    assert_eq!(gemms(), before, "the sequential network handed a GEMM to rayon");
    let out_par = par.forward(x.as_ref()).to_owned();
    let forward_gemms = gemms() - before;
    let gi_par = par.backward(g.as_ref()).to_owned();
    // These shapes go parallel: the 256x256 layer over a batch of 256 (above the threshold; the
    // 14x256 layer is below it) and the backward products; so the comparison is real.
    assert!(forward_gemms >= 1, "no parallel GEMM in the forward pass");
    assert!(gemms() - before > forward_gemms, "no parallel GEMM in the backward pass");
    assert_eq!(out_seq, out_par);
    assert_eq!(gi_seq, gi_par);
    assert_eq!(seq.grads(), par.grads());
    // Other thread counts (more than the machine's cores included) give the same bits.
    for threads in [3, 4, 8] {
        let mut other = seq.clone().with_parallelism(Parallelism::threads(threads));
        other.zero_grad();
        let before = gemms();
        assert_eq!(other.forward(x.as_ref()).to_owned(), out_seq, "{threads} threads");
        assert!(gemms() > before, "{threads} threads: not parallel");
    }

    // A batch-1 pass in between (acting) does not disturb a later batch-256 pass, and each row
    // of a batch equals the same sample alone.
    let one = seq.forward(x.subrows(5, 1)).to_owned();
    assert!((one[(0, 0)] - out_seq[(5, 0)]).abs() <= 1e-5 * (1.0 + one[(0, 0)].abs()));
    assert_eq!(seq.forward(x.as_ref()).to_owned(), out_seq);
    assert_eq!(seq.output().to_owned(), out_seq);
}

#[test]
fn row_major_and_strided_inputs_are_read_correctly() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut mlp = Mlp::new(&[3, 5, 2], Activation::Tanh, Activation::Identity, &mut rng);
    let x = Mat::<f32>::from_fn(4, 3, |i, j| (i as f32) - 0.5 * j as f32);
    let expected = mlp.forward(x.as_ref()).to_owned();
    // The same matrix stored row-major (a replay buffer's layout).
    let flat: Vec<f32> = (0..4).flat_map(|i| (0..3).map(move |j| (i as f32) - 0.5 * j as f32)).collect();
    let row_major = defender_nn::faer::MatRef::from_row_major_slice(&flat, 4, 3);
    assert_eq!(mlp.forward(row_major).to_owned(), expected);
}

#[test]
fn mse_gradient_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let p = Mat::<f32>::from_fn(6, 2, |_, _| rng.random_range(-2.0..2.0));
    let t = Mat::<f32>::from_fn(6, 2, |_, _| rng.random_range(-2.0..2.0));
    let mut g = Mat::<f32>::zeros(6, 2);
    let loss = mse_loss_grad(p.as_ref(), t.as_ref(), g.as_mut());
    assert_eq!(loss, mse_loss(p.as_ref(), t.as_ref()));
    let f = |p: &[f64]| -> f64 {
        let mut s = 0.0;
        for i in 0..6 {
            for j in 0..2 {
                s += (p[i * 2 + j] - t[(i, j)] as f64).powi(2);
            }
        }
        s / 12.0
    };
    let p64: Vec<f64> = (0..12).map(|k| p[(k / 2, k % 2)] as f64).collect();
    close(loss, f(&p64), "mse loss");
    for k in 0..12 {
        let (mut a, mut b) = (p64.clone(), p64.clone());
        a[k] += 1e-6;
        b[k] -= 1e-6;
        close(g[(k / 2, k % 2)], (f(&a) - f(&b)) / 2e-6, &format!("mse grad {k}"));
    }
}
