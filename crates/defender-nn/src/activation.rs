//! Element-wise activations, applied in place and differentiated from their outputs.

/// An element-wise activation function.
///
/// Derivatives are computed from the activation's *output* (ReLU: `y > 0`, tanh: `1 - y^2`), so a
/// network needs to keep only post-activation values for its backward pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Activation {
    /// `y = x`.
    Identity,
    /// `y = max(x, 0)` (derivative 0 at 0, like PyTorch).
    Relu,
    /// `y = tanh(x)`.
    Tanh,
    /// `y = 1 / (1 + exp(-x))` (a probability: Recovery RL's safety critic).
    Sigmoid,
}

impl Activation {
    /// The lower-case name used in files (`identity`, `relu`, `tanh`, `sigmoid`).
    pub fn name(self) -> &'static str {
        match self {
            Activation::Identity => "identity",
            Activation::Relu => "relu",
            Activation::Tanh => "tanh",
            Activation::Sigmoid => "sigmoid",
        }
    }

    /// Parses [`Activation::name`]'s output.
    pub fn from_name(name: &str) -> Option<Activation> {
        match name {
            "identity" => Some(Activation::Identity),
            "relu" => Some(Activation::Relu),
            "tanh" => Some(Activation::Tanh),
            "sigmoid" => Some(Activation::Sigmoid),
            _ => None,
        }
    }

    /// `y = act(x)` for one value.
    #[inline(always)]
    pub fn apply(self, x: f32) -> f32 {
        match self {
            Activation::Identity => x,
            // `x > 0 ? x : 0` keeps the loop branch-free and vectorised.
            Activation::Relu => {
                if x > 0.0 {
                    x
                } else {
                    0.0
                }
            }
            Activation::Tanh => x.tanh(),
            Activation::Sigmoid => sigmoid(x),
        }
    }

    /// `d act / dx` expressed through the output `y = act(x)`.
    #[inline(always)]
    pub fn derivative_from_output(self, y: f32) -> f32 {
        match self {
            Activation::Identity => 1.0,
            Activation::Relu => {
                if y > 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            Activation::Tanh => 1.0 - y * y,
            Activation::Sigmoid => y * (1.0 - y),
        }
    }

    /// `z[i] = act(z[i] + bias[i])` for one sample (a contiguous column); the fused bias and
    /// activation pass after a layer's GEMM.
    #[inline]
    pub(crate) fn bias_apply(self, z: &mut [f32], bias: &[f32]) {
        match self {
            Activation::Identity => z.iter_mut().zip(bias).for_each(|(z, b)| *z += b),
            Activation::Relu => z.iter_mut().zip(bias).for_each(|(z, b)| *z = Activation::Relu.apply(*z + b)),
            Activation::Tanh => z.iter_mut().zip(bias).for_each(|(z, b)| *z = (*z + b).tanh()),
            Activation::Sigmoid => z.iter_mut().zip(bias).for_each(|(z, b)| *z = sigmoid(*z + b)),
        }
    }

    /// `g[i] *= act'(y[i])`: turns a gradient w.r.t. outputs into one w.r.t. pre-activations.
    #[inline]
    pub(crate) fn backprop_in_place(self, g: &mut [f32], y: &[f32]) {
        match self {
            Activation::Identity => {}
            Activation::Relu => g.iter_mut().zip(y).for_each(|(g, y)| {
                if *y <= 0.0 {
                    *g = 0.0
                }
            }),
            Activation::Tanh => g.iter_mut().zip(y).for_each(|(g, y)| *g *= 1.0 - y * y),
            Activation::Sigmoid => g.iter_mut().zip(y).for_each(|(g, y)| *g *= y * (1.0 - y)),
        }
    }
}

/// `1 / (1 + exp(-x))`, written so that neither branch overflows (`exp` of a large positive
/// argument is never taken), as PyTorch's kernel does.
#[inline(always)]
fn sigmoid(x: f32) -> f32 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}
