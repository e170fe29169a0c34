//! PyTorch golden values (torch 2.x on CPU), written by `tools/golden/nn_golden.py` into
//! `tests/data/golden.json`. The snippets below are what the script runs.

#![allow(clippy::unwrap_used)] // tests may unwrap (helpers are outside #[test] fns)

use std::collections::HashMap;

use defender_nn::faer::{Mat, MatRef};
use defender_nn::{Activation, Adam, AdamConfig, Mlp, mse_loss_grad};
use serde::Deserialize;

#[derive(Deserialize)]
struct Tensor {
    shape: Vec<usize>,
    values: Vec<f32>,
}

#[derive(Deserialize)]
struct MlpCase {
    widths: Vec<usize>,
    hidden: String,
    output: String,
    params: HashMap<String, Tensor>,
    input: Tensor,
    target: Tensor,
    output_values: Vec<f32>,
    loss: f32,
    grads: HashMap<String, Tensor>,
    input_grad: Vec<f32>,
}

#[derive(Deserialize)]
struct AdamStep {
    lr: f32,
    grads: HashMap<String, Tensor>,
    params: HashMap<String, Tensor>,
    exp_avg: HashMap<String, Tensor>,
    exp_avg_sq: HashMap<String, Tensor>,
}

#[derive(Deserialize)]
struct AdamCase {
    widths: Vec<usize>,
    initial: HashMap<String, Tensor>,
    steps: Vec<AdamStep>,
}

#[derive(Deserialize)]
struct PolyakCase {
    tau: f32,
    source: Vec<f32>,
    target: Vec<f32>,
    result: Vec<f32>,
}

#[derive(Deserialize)]
struct Golden {
    mlp: Vec<MlpCase>,
    adam: AdamCase,
    polyak: PolyakCase,
}

fn golden() -> Golden {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A parameter-shaped flat vector (`Mlp::params` layout) from PyTorch-named tensors.
fn flat(widths: &[usize], named: &HashMap<String, Tensor>) -> Vec<f32> {
    let mut out = Vec::new();
    for (l, w) in widths.windows(2).enumerate() {
        let weight = &named[&format!("{}.weight", 2 * l)];
        assert_eq!(weight.shape, vec![w[1], w[0]]);
        out.extend_from_slice(&weight.values);
        out.extend_from_slice(&named[&format!("{}.bias", 2 * l)].values);
    }
    out
}

fn row_major(t: &Tensor) -> MatRef<'_, f32> {
    MatRef::from_row_major_slice(&t.values, t.shape[0], t.shape[1])
}

fn assert_close(got: &[f32], want: &[f32], rel: f32, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!((g - w).abs() <= 1e-6 + rel * w.abs(), "{what}[{k}]: got {g}, PyTorch {w}");
    }
}

fn to_row_major(m: MatRef<'_, f32>) -> Vec<f32> {
    (0..m.nrows()).flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)])).collect()
}

/// ```python
/// torch.manual_seed(seed)
/// net = nn.Sequential(nn.Linear(5, 8), nn.ReLU(), nn.Linear(8, 7), nn.ReLU(), nn.Linear(7, 3), nn.Identity())
/// x = torch.randn(batch, 5, requires_grad=True); target = torch.randn(batch, 3)
/// loss = F.mse_loss(net(x), target); loss.backward()   # record out, loss, p.grad, x.grad
/// ```
/// (and the same with Tanh hidden and output activations, widths 3-6-2).
#[test]
fn mlp_forward_backward_matches_pytorch() {
    for case in golden().mlp {
        let hidden = Activation::from_name(&case.hidden).unwrap();
        let output = Activation::from_name(&case.output).unwrap();
        let mut mlp = Mlp::zeros(&case.widths, hidden, output).unwrap();
        mlp.params_mut().copy_from_slice(&flat(&case.widths, &case.params));
        let out = mlp.forward(row_major(&case.input)).to_owned();
        assert_close(&to_row_major(out.as_ref()), &case.output_values, 1e-5, "output");
        let mut grad = Mat::<f32>::zeros(out.nrows(), out.ncols());
        let loss = mse_loss_grad(out.as_ref(), row_major(&case.target), grad.as_mut());
        assert_close(&[loss], &[case.loss], 1e-5, "loss");
        mlp.zero_grad();
        let grad_in = mlp.backward(grad.as_ref()).to_owned();
        assert_close(mlp.grads(), &flat(&case.widths, &case.grads), 1e-4, "parameter gradients");
        assert_close(&to_row_major(grad_in.as_ref()), &case.input_grad, 1e-4, "input gradient");
    }
}

/// ```python
/// opt = torch.optim.Adam(net.parameters(), lr=1e-2, betas=(0.9, 0.999), eps=1e-8)
/// for step in range(5):
///     if step == 3: opt.param_groups[0]["lr"] = 3e-3
///     opt.zero_grad(); F.mse_loss(net(x), target).backward(); opt.step()
///     # record p.grad (before the step), params, state["exp_avg"], state["exp_avg_sq"]
/// ```
/// The gradients are fed as recorded, so this tests the optimiser alone.
#[test]
fn adam_matches_pytorch_over_steps_with_a_learning_rate_change() {
    let case = golden().adam;
    let w = &case.widths;
    let mut mlp = Mlp::zeros(w, Activation::Relu, Activation::Identity).unwrap();
    mlp.params_mut().copy_from_slice(&flat(w, &case.initial));
    let mut opt = Adam::new(&mlp, AdamConfig { lr: 1e-2, ..Default::default() });
    for (k, step) in case.steps.iter().enumerate() {
        opt.set_lr(step.lr);
        mlp.grads_mut().copy_from_slice(&flat(w, &step.grads));
        opt.step(&mut mlp);
        assert_eq!(opt.step_count(), k as u64 + 1);
        assert_close(opt.exp_avg(), &flat(w, &step.exp_avg), 1e-6, &format!("step {k} exp_avg"));
        assert_close(opt.exp_avg_sq(), &flat(w, &step.exp_avg_sq), 1e-5, &format!("step {k} exp_avg_sq"));
        assert_close(mlp.params(), &flat(w, &step.params), 1e-6, &format!("step {k} params"));
    }
}

/// ```python
/// # stable_baselines3.common.utils.polyak_update
/// torch.mul(target, 1 - tau, out=target); torch.add(target, source, alpha=tau, out=target)
/// ```
#[test]
fn polyak_matches_stable_baselines3() {
    let case = golden().polyak;
    let n = case.source.len();
    let mut src = Mlp::zeros(&[1, n / 2], Activation::Identity, Activation::Identity).unwrap();
    src.params_mut().copy_from_slice(&case.source);
    let mut tgt = src.clone();
    tgt.params_mut().copy_from_slice(&case.target);
    tgt.polyak_update(&src, case.tau);
    assert_close(tgt.params(), &case.result, 1e-6, "polyak");
}

/// `golden_sequential.safetensors` holds `net.state_dict()` of the first MLP case with
/// PyTorch's own key names (`0.weight`, `0.bias`, `2.weight`, ...), written by the script.
#[test]
fn loads_a_pytorch_state_dict() {
    let case = golden().mlp.into_iter().next().unwrap();
    let mut mlp = Mlp::zeros(&case.widths, Activation::Relu, Activation::Identity).unwrap();
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden_sequential.safetensors");
    mlp.load_params_safetensors(path).unwrap();
    assert_eq!(mlp.params(), flat(&case.widths, &case.params).as_slice());
    let out = mlp.forward(row_major(&case.input)).to_owned();
    assert_close(&to_row_major(out.as_ref()), &case.output_values, 1e-5, "output");
}
