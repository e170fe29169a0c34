//! The `defender` command line: collect demonstrations, train agents with and without DEFENDER,
//! rank the 576 filtering strategies offline, report the paper's tables and plots, and measure.
// Printing goes through `output` (`say!`, `put!`, `note!`), which never panics.
#![warn(clippy::print_stdout, clippy::print_stderr)]

#[macro_use]
mod output;

mod commands;
mod cost_meter;
mod demo_horizon;
mod eval_line;
mod intervention_line;
mod progress;
mod recovery_agent;
mod resumable;
mod run_dir;
mod run_inputs;
mod safety_agent;
mod setup;
mod signals;
mod sweep;
mod tensorboard;
mod text_table;
mod update_log;

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
    /// Demonstrations: collect safe and unsafe ones by training SAC, as in the paper; measure on
    /// them how far ahead of a crash Recovery RL's safety critic warns.
    #[command(subcommand)]
    Demos(commands::demos::DemosCommand),
    /// Train SAC or TD3 on a task, bare or with DEFENDER, into a run directory.
    Train(Box<commands::train::TrainArgs>),
    /// Rank filtering strategies offline by replaying recorded episodes (SPEC section 7).
    Ablate(commands::ablate::AblateArgs),
    /// Screen the filter's precision variants offline on a bare run's recorded episodes.
    Screen(commands::screen::ScreenArgs),
    /// Choose the strategy for a task from its demonstrations (leave-one-out), before training.
    Select(commands::select::SelectArgs),
    /// Run an experiment file's grid of runs on this machine, N at a time (resumable).
    Sweep(commands::sweep::SweepArgs),
    /// The paper's tables (Markdown, LaTeX, CSV) and learning-curve plots from run directories.
    Report(commands::report::ReportArgs),
    /// Measure the project's performance figures on this machine and print them against targets.
    Bench(commands::bench::BenchArgs),
}

fn main() -> std::process::ExitCode {
    // Output piped into `head` or `less` ends quietly when the reader closes the pipe, as for
    // any Unix tool, instead of a panic from `println!` (Rust ignores SIGPIPE by default).
    // SAFETY: restoring a signal's default disposition before any thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    // Library warnings (MuJoCo's instability warnings among them) reach the user on stderr;
    // RUST_LOG=info (or e.g. mujoco=debug) shows more.
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(true)
        .try_init();
    let result = match cli.command {
        Command::Env(cmd) => commands::env::run(cmd),
        Command::Report(args) => commands::report::run(args),
        Command::Sweep(args) => commands::sweep::run(args),
        Command::Bench(args) => commands::bench::run(args),
        Command::Train(args) => commands::train::run(*args),
        Command::Demos(cmd) => commands::demos::run(cmd),
        Command::Ablate(args) => commands::ablate::run(args),
        Command::Screen(args) => commands::screen::run(args),
        Command::Select(args) => commands::select::run(args),
    };
    match result {
        // The work is done and its files written; what it printed did not reach stdout.
        Ok(()) if output::stdout_error().is_some() => {
            note!("error: cannot write to standard output: {}", output::stdout_error().unwrap_or_default());
            std::process::ExitCode::FAILURE
        }
        Ok(()) => std::process::ExitCode::SUCCESS,
        // A run stopped by a signal has said so; it exits as the signal's convention says.
        Err(err) if err.downcast_ref::<signals::Stopped>().is_some() => {
            std::process::ExitCode::from(err.downcast_ref::<signals::Stopped>().map_or(1, |s| s.code))
        }
        Err(err) => {
            note!("error: {}", describe(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes, `: `-separated, leaving out a cause whose text the message already
/// holds (library errors such as "{path}: {source}" name their source in their own text).
fn describe(err: &anyhow::Error) -> String {
    let mut text = err.to_string();
    for cause in err.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}
