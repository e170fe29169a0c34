//! PyTorch-default initialisation, Polyak averaging and parameter copies.

#![allow(clippy::unwrap_used)] // tests may unwrap (helpers are outside #[test] fns)

use defender_nn::{Activation, Mlp, NnError};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
fn init_is_uniform_within_one_over_sqrt_fan_in_and_seeded() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mlp = Mlp::new(&[16, 256, 4], Activation::Relu, Activation::Identity, &mut rng);
    for (l, fan_in) in [(0usize, 16f32), (1, 256.0)] {
        let bound = 1.0 / fan_in.sqrt();
        let w = mlp.weight(l);
        let mut values: Vec<f32> =
            (0..w.nrows()).flat_map(|i| (0..w.ncols()).map(move |j| w[(i, j)])).collect();
        values.extend_from_slice(mlp.bias(l));
        assert!(values.iter().all(|v| v.abs() <= bound), "layer {l} exceeds its bound {bound}");
        let n = values.len() as f32;
        let mean = values.iter().sum::<f32>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / n;
        // U(-b, b): mean 0, variance b^2 / 3 (4096 and 1028 samples: loose bounds).
        assert!(mean.abs() < 0.1 * bound, "layer {l} mean {mean}");
        assert!((var / (bound * bound / 3.0) - 1.0).abs() < 0.15, "layer {l} variance {var}");
        assert!(values.iter().any(|v| v.abs() > 0.95 * bound));
    }
    let again =
        Mlp::new(&[16, 256, 4], Activation::Relu, Activation::Identity, &mut ChaCha8Rng::seed_from_u64(0));
    assert_eq!(again.params(), mlp.params());
    let other =
        Mlp::new(&[16, 256, 4], Activation::Relu, Activation::Identity, &mut ChaCha8Rng::seed_from_u64(1));
    assert_ne!(other.params(), mlp.params());
}

#[test]
fn polyak_and_copy() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let src = Mlp::new(&[3, 4, 2], Activation::Relu, Activation::Identity, &mut rng);
    let mut tgt = Mlp::new(&[3, 4, 2], Activation::Relu, Activation::Identity, &mut rng);
    let before = tgt.params().to_vec();
    tgt.polyak_update(&src, 0.25);
    for ((t, b), s) in tgt.params().iter().zip(&before).zip(src.params()) {
        assert!((t - (0.25 * s + 0.75 * b)).abs() < 1e-7);
    }
    tgt.polyak_update(&src, 1.0);
    assert_eq!(tgt.params(), src.params());
    let mut fresh = Mlp::zeros(&[3, 4, 2], Activation::Relu, Activation::Identity).unwrap();
    fresh.copy_params_from(&src);
    assert_eq!(fresh.params(), src.params());
}

#[test]
fn invalid_widths_are_errors() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    for widths in [&[][..], &[4][..], &[4, 0, 2][..]] {
        let err = Mlp::try_new(widths, Activation::Relu, Activation::Identity, &mut rng).unwrap_err();
        assert!(matches!(err, NnError::InvalidWidths { .. }), "{err}");
    }
}

#[test]
#[should_panic(expected = "input has 2 columns, the network takes 3 inputs")]
fn wrong_input_width_panics_with_a_clear_message() {
    let mut mlp = Mlp::zeros(&[3, 2], Activation::Relu, Activation::Identity).unwrap();
    let x = defender_nn::faer::Mat::<f32>::zeros(4, 2);
    mlp.forward(x.as_ref());
}
