#![doc = include_str!("../README.md")]

mod batch;
mod error;
mod fast_references;
mod fastdtw;
mod isa;
mod kernel;
#[doc(hidden)]
pub mod kernels;
mod lanes;
mod metric;
#[doc(hidden)]
pub mod oracle;
mod pyramid;
mod references;
mod solver;
mod stream;
mod view;
mod window;

pub use batch::{Dtw, dtw};
pub use error::{DtwError, Result};
pub use fast_references::FastReferences;
pub use fastdtw::{FastDtw, fastdtw};
pub use metric::Metric;
pub use references::References;
pub use stream::Stream;
pub use view::{QueryWindow, RefWindow, View};
