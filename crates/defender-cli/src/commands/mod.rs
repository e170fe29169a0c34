//! One module per subcommand.

pub mod demos;
pub mod env;
pub mod report;
pub mod train;
