#![doc = include_str!("../README.md")]

mod activation;
mod adam;
mod error;
mod io;
mod loss;
mod mlp;
mod parallelism;
mod simd;

pub use activation::Activation;
pub use adam::{Adam, AdamConfig};
pub use error::{NnError, Result};
pub use loss::{mse_loss, mse_loss_grad};
pub use mlp::Mlp;
pub use parallelism::Parallelism;
#[doc(hidden)]
pub use parallelism::parallel_gemms_on_this_thread;

/// Re-export of the `faer` version this crate's matrices come from.
pub use faer;
