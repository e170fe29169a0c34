#![doc = include_str!("../README.md")]

mod batch;
mod error;
mod kernel;
#[doc(hidden)]
pub mod kernels;
mod lanes;
#[doc(hidden)]
pub mod oracle;
mod references;
mod stream;
mod view;

pub use batch::{Dtw, dtw};
pub use error::{DtwError, Result};
pub use references::References;
pub use stream::Stream;
pub use view::{QueryWindow, RefWindow, View};
