//! Safetensors round trips (bit-exact), checkpoint/resume, and loading errors.

#![allow(clippy::unwrap_used)] // tests may unwrap (helpers are outside #[test] fns)

use std::path::PathBuf;

use defender_nn::faer::Mat;
use defender_nn::{Activation, Adam, AdamConfig, Mlp, NnError, mse_loss_grad};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A fresh folder for one test's files, removed when the returned guard drops.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("defender-nn-io-").tempdir().unwrap()
}

fn train_step(mlp: &mut Mlp, opt: &mut Adam, rng: &mut ChaCha8Rng) {
    let x = Mat::<f32>::from_fn(16, mlp.in_dim(), |_, _| rng.random_range(-1.0..1.0));
    let y = Mat::<f32>::from_fn(16, mlp.out_dim(), |_, _| rng.random_range(-1.0..1.0));
    let mut g = Mat::<f32>::zeros(16, mlp.out_dim());
    let out = mlp.forward(x.as_ref());
    mse_loss_grad(out, y.as_ref(), g.as_mut());
    mlp.zero_grad();
    mlp.backward_params(g.as_ref());
    opt.step(mlp);
}

#[test]
fn network_round_trip_is_bit_exact_with_pytorch_names() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mlp = Mlp::new(&[11, 32, 32, 6], Activation::Relu, Activation::Tanh, &mut rng);
    let dir = scratch();
    let path = dir.path().join("actor.safetensors");
    mlp.save_safetensors(&path).unwrap();
    let back = Mlp::load_safetensors(&path).unwrap();
    assert_eq!(back.widths(), mlp.widths());
    assert_eq!(back.hidden_activation(), Activation::Relu);
    assert_eq!(back.output_activation(), Activation::Tanh);
    assert_eq!(
        back.params().iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        mlp.params().iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );

    let bytes = std::fs::read(&path).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let mut names = st.names();
    names.sort();
    assert_eq!(names, ["0.bias", "0.weight", "2.bias", "2.weight", "4.bias", "4.weight"]);
    assert_eq!(st.tensor("2.weight").unwrap().shape(), [32, 32]);
    assert_eq!(st.tensor("0.weight").unwrap().shape(), [32, 11]);
    assert_eq!(st.tensor("4.bias").unwrap().shape(), [6]);
    // Row-major [out, in]: element (1, 2) of layer 0's weight.
    let w = st.tensor("0.weight").unwrap();
    let k = 11 + 2;
    let v = f32::from_le_bytes(w.data()[4 * k..4 * k + 4].try_into().unwrap());
    assert_eq!(v, mlp.weight(0)[(1, 2)]);
}

#[test]
fn checkpoint_resume_is_bit_exact() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut mlp = Mlp::new(&[4, 16, 3], Activation::Relu, Activation::Identity, &mut rng);
    let mut opt = Adam::new(&mlp, AdamConfig { lr: 3e-4, ..Default::default() });
    let mut data = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..3 {
        train_step(&mut mlp, &mut opt, &mut data);
    }
    let dir = scratch();
    let (pn, po) = (dir.path().join("ck.safetensors"), dir.path().join("ck.adam.safetensors"));
    mlp.save_safetensors(&pn).unwrap();
    opt.save_safetensors(&po).unwrap();
    let mut mlp2 = Mlp::load_safetensors(&pn).unwrap();
    let mut opt2 = Adam::load_safetensors(&po, &mlp2).unwrap();
    assert_eq!(opt2, opt);
    let mut data2 = data.clone();
    for _ in 0..3 {
        train_step(&mut mlp, &mut opt, &mut data);
        train_step(&mut mlp2, &mut opt2, &mut data2);
    }
    assert_eq!(mlp.params(), mlp2.params());
    assert_eq!(opt, opt2);
}

fn write_raw(path: &PathBuf, tensors: &[(&str, &str, Vec<usize>)]) {
    // Hand-written safetensors: name, dtype, shape; zero data.
    let mut header = String::from("{");
    let mut offset = 0;
    for (i, (name, dtype, shape)) in tensors.iter().enumerate() {
        let size = shape.iter().product::<usize>() * if *dtype == "F64" { 8 } else { 4 };
        if i > 0 {
            header.push(',');
        }
        header.push_str(&format!(
            "\"{name}\":{{\"dtype\":\"{dtype}\",\"shape\":{shape:?},\"data_offsets\":[{offset},{}]}}",
            offset + size
        ));
        offset += size;
    }
    header.push('}');
    let mut bytes = (header.len() as u64).to_le_bytes().to_vec();
    bytes.extend_from_slice(header.as_bytes());
    bytes.resize(bytes.len() + offset, 0);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn load_errors_name_the_file_the_tensor_and_what_was_expected() {
    let mut mlp = Mlp::zeros(&[3, 4, 2], Activation::Relu, Activation::Identity).unwrap();
    let dir = scratch();
    let path = dir.path().join("bad.safetensors");
    let shown = path.display().to_string();

    write_raw(
        &path,
        &[("0.weight", "F32", vec![4, 3]), ("0.bias", "F32", vec![4]), ("2.weight", "F32", vec![2, 4])],
    );
    let err = mlp.load_params_safetensors(&path).unwrap_err();
    assert!(matches!(err, NnError::MissingTensor { .. }), "{err}");
    let msg = err.to_string();
    assert!(msg.contains(&shown) && msg.contains("`2.bias`") && msg.contains("[2]"), "{msg}");

    write_raw(&path, &[("0.weight", "F32", vec![3, 4]), ("0.bias", "F32", vec![4])]);
    let msg = mlp.load_params_safetensors(&path).unwrap_err().to_string();
    assert!(
        msg.contains(&shown) && msg.contains("`0.weight`") && msg.contains("[3, 4], expected [4, 3]"),
        "{msg}"
    );

    write_raw(&path, &[("0.weight", "F64", vec![4, 3])]);
    let msg = mlp.load_params_safetensors(&path).unwrap_err().to_string();
    assert!(msg.contains("`0.weight`") && msg.contains("F64"), "{msg}");

    let names =
        [("0.weight", vec![4, 3]), ("0.bias", vec![4]), ("2.weight", vec![2, 4]), ("2.bias", vec![2])];
    let mut with_extra: Vec<_> = names.iter().map(|(n, s)| (*n, "F32", s.clone())).collect();
    with_extra.push(("4.weight", "F32", vec![1, 2]));
    write_raw(&path, &with_extra);
    let msg = mlp.load_params_safetensors(&path).unwrap_err().to_string();
    assert!(msg.contains("unexpected tensor `4.weight`"), "{msg}");

    // A PyTorch file has no defender metadata: load_safetensors says what is missing.
    let ok: Vec<_> = names.iter().map(|(n, s)| (*n, "F32", s.clone())).collect();
    write_raw(&path, &ok);
    mlp.load_params_safetensors(&path).unwrap();
    let msg = Mlp::load_safetensors(&path).unwrap_err().to_string();
    assert!(msg.contains("defender.widths"), "{msg}");

    std::fs::write(&path, b"not a safetensors file").unwrap();
    let msg = mlp.load_params_safetensors(&path).unwrap_err().to_string();
    assert!(msg.contains(&shown) && msg.contains("not a valid safetensors"), "{msg}");

    let missing = dir.path().join("does-not-exist.safetensors");
    let err = Mlp::load_safetensors(&missing).unwrap_err();
    assert!(matches!(err, NnError::Io { .. }) && err.to_string().contains("does-not-exist"), "{err}");

    // Optimiser state for another network.
    let other = Mlp::zeros(&[3, 5, 2], Activation::Relu, Activation::Identity).unwrap();
    let opt_path = dir.path().join("other.adam.safetensors");
    Adam::new(&other, AdamConfig::default()).save_safetensors(&opt_path).unwrap();
    let msg = Adam::load_safetensors(&opt_path, &mlp).unwrap_err().to_string();
    assert!(msg.contains("defender.widths") && msg.contains("3,4,2") && msg.contains("3,5,2"), "{msg}");
}
