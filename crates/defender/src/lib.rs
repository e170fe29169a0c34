#![doc = include_str!("../README.md")]

mod atomic;
mod episode_set;
mod error;
mod method;
mod npz;
mod strategy;
mod window;

pub use atomic::write_atomic;
pub use episode_set::{Episode, EpisodeSet, Meta};
pub use error::{DefenderError, Result};
pub use method::{Aggregation, Method};
pub use strategy::{Mode, Strategy};
pub use window::{Span, Window};
