//! `defender env ...`: the MuJoCo tasks.

use clap::Subcommand;

/// `defender env` subcommands.
#[derive(Debug, Subcommand)]
pub enum EnvCommand {
    /// List the tasks with their observation and action dimensions and horizon.
    List,
}

/// Runs an `env` subcommand.
pub fn run(cmd: EnvCommand) -> anyhow::Result<()> {
    match cmd {
        EnvCommand::List => anyhow::bail!("env list: the MuJoCo tasks are not built yet"),
    }
}
