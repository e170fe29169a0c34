//! One module per subcommand.

pub mod ablate;
pub mod bench;
pub mod demos;
pub mod env;
pub mod report;
pub mod safety_flags;
pub mod screen;
pub mod select;
pub mod sweep;
pub mod train;
pub mod train_args;
