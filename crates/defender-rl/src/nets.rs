//! Pieces SAC and TD3 share: matrix helpers, a scalar Adam, network save/load.

use std::path::Path;

use defender_nn::faer::MatRef;
use defender_nn::{Adam, Mlp};
use serde::{Deserialize, Serialize};

use crate::error::RlError;

/// A row-major `rows x cols` view of `data`.
pub(crate) fn rows(data: &[f32], rows: usize, cols: usize) -> MatRef<'_, f32> {
    MatRef::from_row_major_slice(&data[..rows * cols], rows, cols)
}

/// Copies a matrix into a row-major slice.
pub(crate) fn copy_out(m: MatRef<'_, f32>, dst: &mut [f32]) {
    let c = m.ncols();
    for i in 0..m.nrows() {
        for j in 0..c {
            dst[i * c + j] = *m.get(i, j);
        }
    }
}

/// Writes the critic input rows `[obs_i | act_i]` into `dst` (`b x (o + a)`).
pub(crate) fn concat_rows(dst: &mut [f32], obs: &[f32], act: &[f32], b: usize, o: usize, a: usize) {
    for i in 0..b {
        let row = &mut dst[i * (o + a)..(i + 1) * (o + a)];
        row[..o].copy_from_slice(&obs[i * o..(i + 1) * o]);
        row[o..].copy_from_slice(&act[i * a..(i + 1) * a]);
    }
}

/// The squared L2 norm of a network's gradient (summed in f64).
pub(crate) fn grad_sq_norm(net: &Mlp) -> f64 {
    net.grads().iter().map(|&g| f64::from(g) * f64::from(g)).sum()
}

/// torch's `clip_grad_norm_` factor: `max_norm / (norm + 1e-6)`, at most 1.
pub(crate) fn clip_coef(norm: f32, max_norm: f32) -> f32 {
    (max_norm / (norm + 1e-6)).min(1.0)
}

/// Multiplies a network's gradient by `k`.
pub(crate) fn scale_grads(net: &mut Mlp, k: f32) {
    net.grads_mut().iter_mut().for_each(|g| *g *= k);
}

/// Scales a network's gradient to `max_norm` when longer (torch's `clip_grad_norm_`).
pub(crate) fn clip_grad_norm(net: &mut Mlp, max_norm: f32) {
    let k = clip_coef(grad_sq_norm(net).sqrt() as f32, max_norm);
    if k < 1.0 {
        scale_grads(net, k);
    }
}

/// Converts an observation to `f32`, checking its length and values.
pub(crate) fn obs_to_f32(obs: &[f64], dst: &mut [f32]) -> Result<(), RlError> {
    crate::error::check_vector("observation", obs, dst.len())?;
    for (d, &s) in dst.iter_mut().zip(obs) {
        *d = s as f32;
    }
    Ok(())
}

/// Checks an action buffer's length.
pub(crate) fn check_action_len(action: &[f32], act_dim: usize) -> Result<(), RlError> {
    if action.len() != act_dim {
        return Err(crate::EnvError::LengthMismatch {
            name: "action".into(),
            expected: act_dim,
            got: action.len(),
        }
        .into());
    }
    Ok(())
}

/// Adam on one scalar parameter (SAC's `log_alpha`), with `torch.optim.Adam`'s arithmetic
/// exactly as `defender_nn::Adam` does it for whole networks (hyperparameters as the f64 of
/// their decimals, like Python floats; moments in f32).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ScalarAdam {
    lr: f64,
    step: u64,
    m: f32,
    v: f32,
}

impl ScalarAdam {
    pub(crate) fn new(lr: f64) -> Self {
        Self { lr, step: 0, m: 0.0, v: 0.0 }
    }

    /// One step on `p` with gradient `g`.
    pub(crate) fn step(&mut self, p: &mut f32, g: f32) {
        const BETA1: f64 = 0.9;
        const BETA2: f64 = 0.999;
        const EPS: f32 = 1e-8;
        self.step += 1;
        let t = self.step as f64;
        let step_size = (self.lr / (1.0 - BETA1.powf(t))) as f32;
        let bias_correction2_sqrt = (1.0 - BETA2.powf(t)).sqrt() as f32;
        self.m += ((1.0 - BETA1) as f32) * (g - self.m);
        self.v = self.v * (BETA2 as f32) + ((1.0 - BETA2) as f32) * g * g;
        *p -= step_size * (self.m / (self.v.sqrt() / bias_correction2_sqrt + EPS));
    }
}

/// A network with `PyTorch` default initialisation.
pub(crate) fn new_mlp(
    widths: &[usize],
    output: defender_nn::Activation,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Mlp, RlError> {
    Ok(Mlp::try_new(widths, defender_nn::Activation::Relu, output, rng)?)
}

/// `[input, hidden..., output]`.
pub(crate) fn widths(input: usize, hidden: &[usize], output: usize) -> Vec<usize> {
    let mut w = Vec::with_capacity(hidden.len() + 2);
    w.push(input);
    w.extend_from_slice(hidden);
    w.push(output);
    w
}

/// Saves `mlp` as `NAME.safetensors` (and its optimiser as `NAME.adam.safetensors`) in `dir`.
pub(crate) fn save_net(dir: &Path, name: &str, mlp: &Mlp, adam: Option<&Adam>) -> Result<(), RlError> {
    mlp.save_safetensors(dir.join(format!("{name}.safetensors")))?;
    if let Some(adam) = adam {
        adam.save_safetensors(dir.join(format!("{name}.adam.safetensors")))?;
    }
    Ok(())
}

/// Loads what [`save_net`] wrote into `mlp` (and `adam`), checking the shapes.
pub(crate) fn load_net(
    dir: &Path,
    name: &str,
    mlp: &mut Mlp,
    adam: Option<&mut Adam>,
) -> Result<(), RlError> {
    mlp.load_params_safetensors(dir.join(format!("{name}.safetensors")))?;
    if let Some(adam) = adam {
        *adam = Adam::load_safetensors(dir.join(format!("{name}.adam.safetensors")), mlp)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_adam_matches_network_adam() {
        // One-parameter network: the bias of a 1 -> 1 identity layer with a zero weight.
        let mut mlp =
            Mlp::zeros(&[1, 1], defender_nn::Activation::Identity, defender_nn::Activation::Identity)
                .unwrap();
        let mut adam = Adam::new(&mlp, defender_nn::AdamConfig { lr: 3e-4, ..Default::default() });
        let mut scalar = ScalarAdam::new(3e-4);
        let mut p = 0.0f32;
        for k in 0..50 {
            let g = (k as f32 * 0.37).sin() * 2.0;
            mlp.zero_grad();
            mlp.grads_mut()[1] = g;
            adam.step(&mut mlp);
            scalar.step(&mut p, g);
            assert_eq!(p.to_bits(), mlp.params()[1].to_bits(), "step {k}");
        }
    }
}
