//! The multi-layer perceptron: parameters, forward and backward passes over a batch.
//!
//! Layout. All parameters live in one flat `Vec<f32>` (and their gradients in another of the
//! same length), layer by layer, each layer as `weight` then `bias`. A weight is stored like
//! PyTorch's `[out, in]` row-major tensor, which is faer's column-major `in x out` matrix `Wt`.
//! Activations are stored "columns = samples": a layer's output is a column-major
//! `out x batch` matrix, so each sample is a contiguous column and the bias + activation pass
//! is a vectorised loop per column. The public API speaks "rows = samples" (`batch x features`)
//! and hands out transposed views, which cost nothing.
//!
//! For layer `l` with input `X` (`in x B`) and pre-activation `Z` (`out x B`):
//! forward `Z = Wt^T X`, `Y = act(Z + b)`;
//! backward `dWt += X dZ^T`, `db += sum_j dZ[:, j]`, `dX = Wt dZ`.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef};
use rand::Rng;

use crate::{Activation, NnError, Parallelism, Result};

/// Where a layer's parameters sit in the flat parameter vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LayerSlot {
    /// Input width (`fan_in`).
    pub fan_in: usize,
    /// Output width.
    pub fan_out: usize,
    /// Offset of the weight (`fan_out * fan_in` values, PyTorch `[out, in]` row-major).
    pub weight: usize,
    /// Offset of the bias (`fan_out` values).
    pub bias: usize,
}

/// What a backward pass computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wanted {
    ParamsAndInput,
    InputOnly,
    ParamsOnly,
}

/// Preallocated buffers of the forward and backward passes. They grow to the largest batch
/// seen and never shrink, so steady-state passes allocate nothing.
#[derive(Debug, Clone, Default)]
struct Workspace {
    /// Batch size of the last forward pass (0 before any).
    batch: usize,
    /// `acts[0]` is a copy of the input (`in x B`), `acts[l + 1]` the output of layer `l`.
    acts: Vec<Vec<f32>>,
    /// Gradient w.r.t. the current layer's pre-activation (`out x B`).
    grad: Vec<f32>,
    /// Gradient w.r.t. the current layer's input (`in x B`); swapped with `grad` per layer.
    grad_next: Vec<f32>,
    /// Width of the matrix last left in `grad` (the input gradient after a backward pass).
    grad_rows: usize,
}

fn ensure_len(v: &mut Vec<f32>, n: usize) {
    if v.len() < n {
        v.resize(n, 0.0);
    }
}

/// A multi-layer perceptron `Linear -> act -> Linear -> act -> ... -> Linear -> out_act`, f32.
///
/// `widths = [in, h1, ..., out]` gives `widths.len() - 1` linear layers; every layer but the
/// last is followed by the `hidden` activation, the last by `output`. A single linear layer is
/// `Mlp::new(&[in, out], Activation::Identity, Activation::Identity, rng)`.
///
/// Matrices are `batch x features` ("rows = samples") at the API. [`Mlp::forward`] keeps what
/// the backward pass needs; [`Mlp::backward`] accumulates parameter gradients (like PyTorch's
/// `.grad`, cleared by [`Mlp::zero_grad`]) and returns the gradient w.r.t. the input;
/// [`Mlp::backward_input`] returns the input gradient only and leaves parameter gradients
/// untouched (the actor update through a critic).
#[derive(Debug, Clone)]
pub struct Mlp {
    widths: Vec<usize>,
    hidden: Activation,
    output: Activation,
    slots: Vec<LayerSlot>,
    params: Vec<f32>,
    grads: Vec<f32>,
    parallelism: Parallelism,
    ws: Workspace,
}

impl Mlp {
    /// A network with PyTorch's default initialisation (see [`Mlp::init_pytorch_default`]),
    /// drawing from `rng`.
    ///
    /// # Panics
    ///
    /// If `widths` has fewer than two entries or a zero entry; [`Mlp::try_new`] returns an
    /// error instead.
    #[track_caller]
    pub fn new<R: Rng + ?Sized>(
        widths: &[usize],
        hidden: Activation,
        output: Activation,
        rng: &mut R,
    ) -> Self {
        match Self::try_new(widths, hidden, output, rng) {
            Ok(mlp) => mlp,
            Err(e) => panic!("{e}"),
        }
    }

    /// Like [`Mlp::new`], returning an error for invalid widths.
    ///
    /// # Errors
    ///
    /// [`NnError::InvalidWidths`] if `widths` has fewer than two entries or a zero entry.
    pub fn try_new<R: Rng + ?Sized>(
        widths: &[usize],
        hidden: Activation,
        output: Activation,
        rng: &mut R,
    ) -> Result<Self> {
        let mut mlp = Self::zeros(widths, hidden, output)?;
        mlp.init_pytorch_default(rng);
        Ok(mlp)
    }

    /// A network with all parameters zero (to be filled by a loader or by hand).
    ///
    /// # Errors
    ///
    /// [`NnError::InvalidWidths`] if `widths` has fewer than two entries or a zero entry.
    pub fn zeros(widths: &[usize], hidden: Activation, output: Activation) -> Result<Self> {
        if widths.len() < 2 {
            return Err(NnError::InvalidWidths {
                widths: widths.to_vec(),
                reason: "need at least an input and an output width",
            });
        }
        if widths.contains(&0) {
            return Err(NnError::InvalidWidths {
                widths: widths.to_vec(),
                reason: "widths must be positive",
            });
        }
        let mut slots = Vec::with_capacity(widths.len() - 1);
        let mut offset = 0;
        for w in widths.windows(2) {
            let (fan_in, fan_out) = (w[0], w[1]);
            slots.push(LayerSlot { fan_in, fan_out, weight: offset, bias: offset + fan_in * fan_out });
            offset += fan_in * fan_out + fan_out;
        }
        let ws = Workspace { acts: vec![Vec::new(); widths.len()], ..Default::default() };
        Ok(Mlp {
            widths: widths.to_vec(),
            hidden,
            output,
            slots,
            params: vec![0.0; offset],
            grads: vec![0.0; offset],
            parallelism: Parallelism::default(),
            ws,
        })
    }

    /// PyTorch's `nn.Linear` initialisation: every weight and bias of a layer with `fan_in`
    /// inputs drawn from `U(-1/sqrt(fan_in), 1/sqrt(fan_in))` (that is what
    /// `kaiming_uniform_(a=sqrt(5))` reduces to). Layer by layer, weight (row-major `[out, in]`)
    /// then bias, from `rng`.
    pub fn init_pytorch_default<R: Rng + ?Sized>(&mut self, rng: &mut R) {
        for slot in &self.slots {
            let bound = 1.0 / (slot.fan_in as f32).sqrt();
            let end = slot.bias + slot.fan_out;
            for p in &mut self.params[slot.weight..end] {
                // u in [0, 1): p in [-bound, bound).
                *p = (2.0 * rng.random::<f32>() - 1.0) * bound;
            }
        }
    }

    /// Layer widths `[in, h1, ..., out]`.
    pub fn widths(&self) -> &[usize] {
        &self.widths
    }

    /// Input width.
    pub fn in_dim(&self) -> usize {
        self.widths[0]
    }

    /// Output width.
    pub fn out_dim(&self) -> usize {
        self.widths[self.widths.len() - 1]
    }

    /// Number of linear layers.
    pub fn num_layers(&self) -> usize {
        self.slots.len()
    }

    /// The activation after every layer but the last.
    pub fn hidden_activation(&self) -> Activation {
        self.hidden
    }

    /// The activation after the last layer.
    pub fn output_activation(&self) -> Activation {
        self.output
    }

    /// The threading of the GEMMs.
    pub fn parallelism(&self) -> Parallelism {
        self.parallelism
    }

    /// Sets the threading of the GEMMs (`Parallelism::Sequential` forces one thread).
    pub fn set_parallelism(&mut self, parallelism: Parallelism) {
        self.parallelism = parallelism;
    }

    /// Builder form of [`Mlp::set_parallelism`].
    pub fn with_parallelism(mut self, parallelism: Parallelism) -> Self {
        self.parallelism = parallelism;
        self
    }

    /// Total number of parameters.
    pub fn num_params(&self) -> usize {
        self.params.len()
    }

    /// All parameters, flat: per layer, the weight (PyTorch `[out, in]` row-major) then the bias.
    pub fn params(&self) -> &[f32] {
        &self.params
    }

    /// Mutable [`Mlp::params`].
    pub fn params_mut(&mut self) -> &mut [f32] {
        &mut self.params
    }

    /// Accumulated gradients, laid out like [`Mlp::params`].
    pub fn grads(&self) -> &[f32] {
        &self.grads
    }

    /// Mutable [`Mlp::grads`] (e.g. to scale or clip them).
    pub fn grads_mut(&mut self) -> &mut [f32] {
        &mut self.grads
    }

    /// Parameters and gradients at once (what an optimiser needs).
    pub fn params_and_grads_mut(&mut self) -> (&mut [f32], &[f32]) {
        (&mut self.params, &self.grads)
    }

    pub(crate) fn slots(&self) -> &[LayerSlot] {
        &self.slots
    }

    /// Layer `l`'s weight as an `out x in` matrix (PyTorch's shape).
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn weight(&self, l: usize) -> MatRef<'_, f32> {
        let s = self.slots[l];
        MatRef::from_column_major_slice(&self.params[s.weight..s.bias], s.fan_in, s.fan_out).transpose()
    }

    /// Mutable [`Mlp::weight`].
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn weight_mut(&mut self, l: usize) -> MatMut<'_, f32> {
        let s = self.slots[l];
        MatMut::from_column_major_slice_mut(&mut self.params[s.weight..s.bias], s.fan_in, s.fan_out)
            .transpose_mut()
    }

    /// Layer `l`'s bias.
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn bias(&self, l: usize) -> &[f32] {
        let s = self.slots[l];
        &self.params[s.bias..s.bias + s.fan_out]
    }

    /// Mutable [`Mlp::bias`].
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn bias_mut(&mut self, l: usize) -> &mut [f32] {
        let s = self.slots[l];
        &mut self.params[s.bias..s.bias + s.fan_out]
    }

    /// Gradient of layer `l`'s weight, `out x in`.
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn weight_grad(&self, l: usize) -> MatRef<'_, f32> {
        let s = self.slots[l];
        MatRef::from_column_major_slice(&self.grads[s.weight..s.bias], s.fan_in, s.fan_out).transpose()
    }

    /// Gradient of layer `l`'s bias.
    ///
    /// # Panics
    ///
    /// If `l >= num_layers()`.
    pub fn bias_grad(&self, l: usize) -> &[f32] {
        let s = self.slots[l];
        &self.grads[s.bias..s.bias + s.fan_out]
    }

    /// Sets all gradients to zero.
    pub fn zero_grad(&mut self) {
        self.grads.fill(0.0);
    }

    /// `self = source` for the parameters (hard target-network update).
    ///
    /// # Panics
    ///
    /// If the two networks have different widths.
    #[track_caller]
    pub fn copy_params_from(&mut self, source: &Mlp) {
        self.assert_same_shape(source);
        self.params.copy_from_slice(&source.params);
    }

    /// Polyak averaging of the parameters: `self = tau * source + (1 - tau) * self`, computed
    /// as Stable-Baselines3 does (`self *= 1 - tau; self += tau * source`).
    ///
    /// # Panics
    ///
    /// If the two networks have different widths.
    #[track_caller]
    pub fn polyak_update(&mut self, source: &Mlp, tau: f32) {
        self.assert_same_shape(source);
        let keep = 1.0 - tau;
        for (t, s) in self.params.iter_mut().zip(&source.params) {
            *t = *t * keep + tau * *s;
        }
    }

    #[track_caller]
    fn assert_same_shape(&self, other: &Mlp) {
        assert!(self.widths == other.widths, "MLP widths differ: {:?} vs {:?}", self.widths, other.widths);
    }

    /// The forward pass over a batch: `input` is `batch x in` (rows = samples, any strides);
    /// returns the `batch x out` output, valid until the next pass. Keeps the activations for
    /// a following backward pass. Allocates only when the batch is larger than any before.
    ///
    /// # Panics
    ///
    /// If `input.ncols() != in_dim()`.
    #[track_caller]
    pub fn forward(&mut self, input: MatRef<'_, f32>) -> MatRef<'_, f32> {
        assert!(
            input.ncols() == self.in_dim(),
            "Mlp::forward: input has {} columns, the network takes {} inputs",
            input.ncols(),
            self.in_dim()
        );
        let b = input.nrows();
        self.ws.batch = b;
        for (acts, &w) in self.ws.acts.iter_mut().zip(&self.widths) {
            ensure_len(acts, w * b);
        }
        let n_in = self.in_dim();
        MatMut::from_column_major_slice_mut(&mut self.ws.acts[0][..n_in * b], n_in, b)
            .copy_from(input.transpose());
        let last = self.slots.len() - 1;
        for (l, s) in self.slots.iter().enumerate() {
            let (done, rest) = self.ws.acts.split_at_mut(l + 1);
            let x = MatRef::from_column_major_slice(&done[l][..s.fan_in * b], s.fan_in, b);
            let z_slice = &mut rest[0][..s.fan_out * b];
            let wt = MatRef::from_column_major_slice(&self.params[s.weight..s.bias], s.fan_in, s.fan_out);
            if b > 0 {
                matmul(
                    MatMut::from_column_major_slice_mut(z_slice, s.fan_out, b),
                    Accum::Replace,
                    wt.transpose(),
                    x,
                    1.0,
                    self.parallelism.for_gemm(s.fan_out, b, s.fan_in),
                );
            }
            let act = if l == last { self.output } else { self.hidden };
            let bias = &self.params[s.bias..s.bias + s.fan_out];
            crate::simd::vectorized(
                #[inline(always)]
                || {
                    for col in z_slice.chunks_exact_mut(s.fan_out) {
                        act.bias_apply(col, bias);
                    }
                },
            );
        }
        let out = self.out_dim();
        MatRef::from_column_major_slice(&self.ws.acts[last + 1][..out * b], out, b).transpose()
    }

    /// The output of the last forward pass, `batch x out`.
    pub fn output(&self) -> MatRef<'_, f32> {
        let (b, out) = (self.ws.batch, self.out_dim());
        match self.ws.acts.last() {
            Some(a) if a.len() >= out * b => {
                MatRef::from_column_major_slice(&a[..out * b], out, b).transpose()
            }
            _ => MatRef::from_column_major_slice(&[], 0, 0),
        }
    }

    /// The backward pass of the last forward pass: given `grad_out = dL/d(output)`
    /// (`batch x out`), *adds* `dL/d(params)` to the gradients and returns `dL/d(input)`
    /// (`batch x in`), valid until the next pass.
    ///
    /// # Panics
    ///
    /// If `grad_out` is not `batch x out` for the batch of the last forward pass.
    #[track_caller]
    pub fn backward(&mut self, grad_out: MatRef<'_, f32>) -> MatRef<'_, f32> {
        self.backward_impl(grad_out, Wanted::ParamsAndInput);
        self.input_grad()
    }

    /// Like [`Mlp::backward`] but computes only `dL/d(input)`: the parameter gradients are
    /// left untouched and their GEMMs skipped. This is the actor update's pass through the
    /// critic (`dQ/da`).
    ///
    /// # Panics
    ///
    /// If `grad_out` is not `batch x out` for the batch of the last forward pass.
    #[track_caller]
    pub fn backward_input(&mut self, grad_out: MatRef<'_, f32>) -> MatRef<'_, f32> {
        self.backward_impl(grad_out, Wanted::InputOnly);
        self.input_grad()
    }

    /// Like [`Mlp::backward`] but skips `dL/d(input)` (one GEMM fewer): for networks whose
    /// input is data.
    ///
    /// # Panics
    ///
    /// If `grad_out` is not `batch x out` for the batch of the last forward pass.
    #[track_caller]
    pub fn backward_params(&mut self, grad_out: MatRef<'_, f32>) {
        self.backward_impl(grad_out, Wanted::ParamsOnly);
    }

    fn input_grad(&self) -> MatRef<'_, f32> {
        let (b, n) = (self.ws.batch, self.ws.grad_rows);
        MatRef::from_column_major_slice(&self.ws.grad[..n * b], n, b).transpose()
    }

    #[track_caller]
    fn backward_impl(&mut self, grad_out: MatRef<'_, f32>, wanted: Wanted) {
        let b = self.ws.batch;
        let out = self.out_dim();
        assert!(
            grad_out.nrows() == b && grad_out.ncols() == out,
            "Mlp::backward: grad_out is {}x{}, expected {b}x{out} (batch x out of the last forward)",
            grad_out.nrows(),
            grad_out.ncols()
        );
        let max_w = self.widths.iter().copied().max().unwrap_or(0);
        ensure_len(&mut self.ws.grad, max_w * b);
        ensure_len(&mut self.ws.grad_next, max_w * b);
        let ws = &mut self.ws;
        MatMut::from_column_major_slice_mut(&mut ws.grad[..out * b], out, b).copy_from(grad_out.transpose());
        let last = self.slots.len() - 1;
        self.output.backprop_in_place(&mut ws.grad[..out * b], &ws.acts[last + 1][..out * b]);
        ws.grad_rows = out;
        for (l, s) in self.slots.iter().enumerate().rev() {
            let x = MatRef::from_column_major_slice(&ws.acts[l][..s.fan_in * b], s.fan_in, b);
            let dz_slice = &ws.grad[..s.fan_out * b];
            let dz = MatRef::from_column_major_slice(dz_slice, s.fan_out, b);
            if wanted != Wanted::InputOnly && b > 0 {
                let dwt = MatMut::from_column_major_slice_mut(
                    &mut self.grads[s.weight..s.bias],
                    s.fan_in,
                    s.fan_out,
                );
                let par = self.parallelism.for_gemm(s.fan_in, s.fan_out, b);
                matmul(dwt, Accum::Add, x, dz.transpose(), 1.0, par);
                let db = &mut self.grads[s.bias..s.bias + s.fan_out];
                crate::simd::vectorized(
                    #[inline(always)]
                    || {
                        for col in dz_slice.chunks_exact(s.fan_out) {
                            db.iter_mut().zip(col).for_each(|(d, g)| *d += g);
                        }
                    },
                );
            }
            if l == 0 && wanted == Wanted::ParamsOnly {
                break;
            }
            let dx_slice = &mut ws.grad_next[..s.fan_in * b];
            if b > 0 {
                let wt = MatRef::from_column_major_slice(&self.params[s.weight..s.bias], s.fan_in, s.fan_out);
                let par = self.parallelism.for_gemm(s.fan_in, b, s.fan_out);
                let dx = MatMut::from_column_major_slice_mut(dx_slice, s.fan_in, b);
                matmul(dx, Accum::Replace, wt, dz, 1.0, par);
            }
            if l > 0 {
                let y = &ws.acts[l][..s.fan_in * b];
                crate::simd::vectorized(
                    #[inline(always)]
                    || self.hidden.backprop_in_place(dx_slice, y),
                );
            }
            std::mem::swap(&mut ws.grad, &mut ws.grad_next);
            ws.grad_rows = s.fan_in;
        }
    }
}
