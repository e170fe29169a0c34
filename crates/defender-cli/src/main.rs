//! The `defender` command line: collect demonstrations, train agents with and without DEFENDER,
//! rank the 576 filtering strategies offline, report the paper's tables and plots, and measure.

mod commands;

use clap::{Parser, Subcommand};

/// DEFENDER: DTW-based episode filtering using demonstrations, for safer RL training.
#[derive(Debug, Parser)]
#[command(name = "defender", version, about, long_about = None, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The MuJoCo tasks: list them, replay recorded actions from a given state.
    #[command(subcommand)]
    Env(commands::env::EnvCommand),
    /// The paper's tables (Markdown, LaTeX, CSV) and learning-curve plots from run directories.
    Report(commands::report::ReportArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Env(cmd) => commands::env::run(cmd),
        Command::Report(args) => commands::report::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
