//! TensorBoard event files: the format ([`event_file`]), what a training run writes into its
//! run directory ([`board`]), and `defender report --tensorboard`, which writes them from the
//! CSV files of runs that predate them ([`convert`]).

pub mod board;
pub mod convert;
pub mod event_file;
