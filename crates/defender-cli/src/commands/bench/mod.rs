//! `defender bench`: the project's performance figures, measured now on this machine, as one
//! table (what, value, unit, target, met or not).
//!
//! Every figure is a short timed loop over the library APIs with a warm-up; the value is a
//! median or a best-of-k (said in the row's notes). Training figures run the real trainer on
//! Hopper-v5 with `learning_starts = 256` so that the measured steps all include the
//! environment step and one gradient step. DEFENDER's overhead (the paper's % Time) is the wall
//! time of those measured steps on `DefenderEnv` over the same steps of the bare run, same seed.
//! Micro-figures of one kernel (batch and streaming DTW, the filter per step, the networks) are
//! the crates' criterion benches (`make bench`).

mod clock;
mod demos;
mod figures;
mod machine;
mod row;
mod runs;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::bail;
use clap::{Args, ValueEnum};
use defender_rl::{Algo, Parallelism};

use figures::Bench;
use machine::{load_average, machine};
use row::Row;

const BENCH_HELP: &str = "\
Figures (names for --only, in the order they run):
  mujoco     env steps/s per task, random actions (Hopper-v5 target >= 5000)
  sac, td3   training steps/s on Hopper-v5, env step + one update (targets 150 / 200)
  overhead   DEFENDER's % Time for SAC on Hopper-v5, the paper's 3 state strategies in both
             modes, default settings (targets <= 105 % state, <= 115 % state-action)
  dynamics   the dynamics model's share of the overhead: SPEC's schedule against the default
             (as `defender train` runs it: on the model's own thread with 2+ network threads),
             the default on the calling thread, and SPEC's on the model's own thread

DTW and the filter per step are measured by the crates' criterion benches:
  cargo bench -p defender-dtw; cargo bench -p defender --bench filter

Training runs take 256 warm-up steps (not timed) and then --steps timed steps (default 2000,
200 with --quick), seed 0. % Time = wall time of the DEFENDER run's timed steps / the bare
SAC run's (mean of the bare runs made before and after) x 100; filtered steps end episodes
early, so runs are compared over equal step counts. The machine's load average is printed
before and after: on a shared machine, re-run when it is idle.

Demonstrations: data/demos/Hopper-v5.npz if it exists (first 50 of each group), else
synthetic Hopper-shaped ones (50 safe + 50 unsafe smooth random walks of 1000 steps, 11-D;
the unsafe ones far away, so that the filter never fires and every training step is a real
one: the upper bound of the overhead; with real demonstrations, filtered steps skip the
environment and the dynamics model's training and cost less).

Examples:
  defender bench                        # everything, a few minutes
  defender bench --quick                # everything, shorter loops
  defender bench --only mujoco,sac
  defender bench --only overhead,dynamics --steps 5000 --threads 1";

/// Arguments of `defender bench`.
#[derive(Debug, Args)]
#[command(after_help = BENCH_HELP)]
pub struct BenchArgs {
    /// Shorter loops (fewer repetitions, 200 training steps): a rough check.
    #[arg(long)]
    quick: bool,
    /// Run only these figures (comma-separated; see the list below).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    only: Vec<Figure>,
    /// Timed training steps per training run (after 256 warm-up steps).
    #[arg(long, value_name = "N")]
    steps: Option<u64>,
    /// Threads for the networks' GEMMs (agent and dynamics model); default: DEFENDER_NN_THREADS,
    /// else min(2, cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Demonstration set (.npz) for the overhead and dynamics figures [default:
    /// data/demos/Hopper-v5.npz if it exists, else synthetic].
    #[arg(long, value_name = "FILE.npz", conflicts_with = "synthetic")]
    demos: Option<PathBuf>,
    /// Use synthetic Hopper-shaped demonstrations even if data/demos/Hopper-v5.npz exists.
    #[arg(long)]
    synthetic: bool,
}

/// A figure, in the order they run (the order of the variants).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, ValueEnum)]
pub enum Figure {
    Mujoco,
    Sac,
    Td3,
    Overhead,
    Dynamics,
}

impl Figure {
    /// The name `--only` takes and the table's first column shows.
    pub fn name(self) -> &'static str {
        match self {
            Figure::Mujoco => "mujoco",
            Figure::Sac => "sac",
            Figure::Td3 => "td3",
            Figure::Overhead => "overhead",
            Figure::Dynamics => "dynamics",
        }
    }

    fn trains(self) -> bool {
        !matches!(self, Figure::Mujoco)
    }

    fn needs_demos(self) -> bool {
        matches!(self, Figure::Overhead | Figure::Dynamics)
    }
}

pub(super) const SEED: u64 = 0;
pub(super) const LEARNING_STARTS: u64 = 256;
pub(super) const TASK: &str = "Hopper-v5";

/// Runs `defender bench`.
///
/// # Errors
/// `--steps 0` or `--threads 0`, an unusable demonstration file, or a failure of the code being
/// measured.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let selected = select(&args.only);
    if args.steps == Some(0) {
        bail!("--steps must be at least 1 (timed training steps per run)");
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let (par, threads_from) = match args.threads {
        Some(n) => (Parallelism::threads(n), "--threads".to_string()),
        None => (
            Parallelism::default(),
            match std::env::var("DEFENDER_NN_THREADS") {
                Ok(v) => format!("DEFENDER_NN_THREADS={v}"),
                Err(_) => "default: min(2, cores)".to_string(),
            },
        ),
    };
    let demos = if selected.iter().any(|f| f.needs_demos()) {
        Some(demos::load_demos(args.demos.as_deref(), args.synthetic)?)
    } else {
        None
    };
    let mut bench = Bench {
        quick: args.quick,
        steps: args.steps.unwrap_or(if args.quick { 200 } else { 2000 }),
        par,
        demos,
        selected: selected.clone(),
        contest: None,
        progress: std::io::stderr().is_terminal(),
    };

    let started = Instant::now();
    let load_before = load_average();
    let names: Vec<&str> = selected.iter().map(|f| f.name()).collect();
    say!("defender bench ({}): {}", if args.quick { "quick" } else { "full" }, names.join(", "));
    say!("machine:  {}; load average {} (1/5/15 min) at start", machine(), load_before);
    say!("threads:  networks {} ({threads_from}); MuJoCo on one thread", par.num_threads());
    if selected.iter().any(|f| f.trains()) {
        say!(
            "training: {TASK}, seed {SEED}, {LEARNING_STARTS} warm-up steps then {} timed steps per run",
            bench.steps
        );
    }
    if let Some(d) = &bench.demos {
        say!("demos:    {}", d.label);
    }
    say!();

    let mut rows = Vec::new();
    for &figure in &selected {
        bench.note(&format!("running {} ...", figure.name()));
        let t = Instant::now();
        let new = match figure {
            Figure::Mujoco => bench.mujoco()?,
            Figure::Sac => bench.training(Algo::Sac)?,
            Figure::Td3 => bench.training(Algo::Td3)?,
            Figure::Overhead => bench.overhead()?,
            Figure::Dynamics => bench.dynamics()?,
        };
        bench.note(&format!("{} done in {:.1} s", figure.name(), t.elapsed().as_secs_f64()));
        rows.extend(new);
    }

    put!("{}", row::table(&rows));
    let with_target: Vec<&Row> = rows.iter().filter(|r| r.target.is_some()).collect();
    let missed: Vec<String> =
        with_target.iter().filter(|r| !r.met().unwrap_or(true)).map(|r| r.short()).collect();
    say!();
    say!("targets met: {} of {}", with_target.len() - missed.len(), with_target.len());
    for m in &missed {
        say!("  not met: {m}");
    }
    say!("load average {} at end; {:.0} s in total", load_average(), started.elapsed().as_secs_f64());
    Ok(())
}

/// The figures to run, each once, in their canonical order (all of them when `--only` is not
/// given).
fn select(only: &[Figure]) -> Vec<Figure> {
    let mut figures = if only.is_empty() { Figure::value_variants().to_vec() } else { only.to_vec() };
    figures.sort();
    figures.dedup();
    figures
}
