#![doc = include_str!("../README.md")]

mod error;
mod kernel;
#[doc(hidden)]
pub mod kernels;
mod lanes;
mod references;
mod settings;
mod stream;
mod view;

pub use error::{DtwError, Result};
pub use references::References;
pub use settings::{Dtw, dtw};
pub use stream::Stream;
pub use view::{QueryWindow, RefWindow, View};
