//! Small pure-Rust control tasks for fast tests (no simulator needed).

mod pendulum;

pub use pendulum::Pendulum;
