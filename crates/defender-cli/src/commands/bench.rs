//! `defender bench`: the project's performance figures, measured now on this machine, as one
//! table (what, value, unit, target, met or not).
//!
//! Every figure is a short timed loop over the library APIs with a warm-up; the value is a
//! median or a best-of-k (said in the row's notes). Training figures run the real trainer on
//! Hopper-v5 with `learning_starts = 256` so that the measured steps all include the
//! environment step and one gradient step. DEFENDER's overhead (the paper's % Time) is the wall
//! time of those measured steps on `DefenderEnv` over the same steps of the bare run, same seed.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use defender::synthetic::{WalkSet, random_walk as walk};
use defender::{
    CostOptions, DefenderConfig, DefenderEnv, Demonstrations, DynamicsConfig, DynamicsModel, EpisodeSet,
    Filter, Meta, Mode, Strategy,
};
use defender_dtw::{Dtw, QueryWindow, RefWindow, References, View, dtw};
use defender_mujoco::MujocoEnv;
use defender_nn::Parallelism;
use defender_rl::{
    Agent, Algo, Budget, Env, EpisodeRecord, HookError, Hooks, Sac, SacConfig, Td3, Td3Config, TimeLimit,
    Trainer, TrainerConfig,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const BENCH_HELP: &str = "\
Figures (names for --only, in the order they run):
  mujoco     env steps/s per task, random actions (Hopper-v5 target >= 5000)
  dtw-batch  batch DTW, 1000 x 1000, d = 11, in M cells/s (target >= 500)
  dtw-push   one streaming push against 100 refs x 1000, d = 11, (All, All) (target <= 200 us)
  filter     DEFENDER filter per step, 4 strategies (targets <= 10 us, <= 2 ms)
  sac, td3   training steps/s on Hopper-v5, env step + one update (targets 150 / 200)
  overhead   DEFENDER's % Time for SAC on Hopper-v5, the paper's 3 state strategies in both
             modes, default settings (targets <= 105 % state, <= 115 % state-action)
  dynamics   the dynamics model's share of the overhead: SPEC's schedule against the default,
             and SPEC's on its own thread ([defender.dynamics] background = true)

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
  defender bench --quick                # everything, shorter loops (~20-40 s)
  defender bench --only dtw-batch,filter
  defender bench --only overhead,dynamics --steps 5000 --threads 1";

/// Arguments of `defender bench`.
#[derive(Debug, Args)]
#[command(after_help = BENCH_HELP)]
pub struct BenchArgs {
    /// Shorter loops (fewer repetitions, 200 training steps): a rough check in under a minute.
    #[arg(long)]
    quick: bool,
    /// Run only these figures (comma-separated; see the list below).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    only: Vec<String>,
    /// Timed training steps per training run (after 256 warm-up steps).
    #[arg(long, value_name = "N")]
    steps: Option<u64>,
    /// Threads for the networks' GEMMs (agent and dynamics model); default: DEFENDER_NN_THREADS,
    /// else min(2, cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Demonstration set (.npz) for the filter and overhead figures [default:
    /// data/demos/Hopper-v5.npz if it exists, else synthetic].
    #[arg(long, value_name = "FILE.npz", conflicts_with = "synthetic")]
    demos: Option<PathBuf>,
    /// Use synthetic Hopper-shaped demonstrations even if data/demos/Hopper-v5.npz exists.
    #[arg(long)]
    synthetic: bool,
}

/// The figures, in the order they run.
const FIGURES: [&str; 8] =
    ["mujoco", "dtw-batch", "dtw-push", "filter", "sac", "td3", "overhead", "dynamics"];

const SEED: u64 = 0;
const LEARNING_STARTS: u64 = 256;
const TASK: &str = "Hopper-v5";
const DEFAULT_DEMOS: &str = "data/demos/Hopper-v5.npz";
/// Demonstrations per group, as in the paper's Hopper experiments.
const DEMOS_PER_GROUP: usize = 50;
/// Added to every observation of the synthetic unsafe demonstrations.
const UNSAFE_OFFSET: f32 = 1000.0;

/// Runs `defender bench`.
///
/// # Errors
/// An unknown figure name, `--steps 0` or `--threads 0`, an unusable demonstration file, or a
/// failure of the code being measured.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let selected = select(&args.only)?;
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
    let needs_demos = selected.iter().any(|f| ["filter", "overhead", "dynamics"].contains(f));
    let demos = if needs_demos { Some(load_demos(args.demos.as_deref(), args.synthetic)?) } else { None };
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
    println!("defender bench ({}): {}", if args.quick { "quick" } else { "full" }, selected.join(", "));
    println!("machine:  {}; load average {} (1/5/15 min) at start", machine(), load_before);
    println!(
        "threads:  networks {} ({threads_from}); DTW, filter and MuJoCo on one thread",
        par.num_threads()
    );
    if selected.iter().any(|f| ["sac", "td3", "overhead", "dynamics"].contains(f)) {
        println!(
            "training: {TASK}, seed {SEED}, {LEARNING_STARTS} warm-up steps then {} timed steps per run",
            bench.steps
        );
    }
    if let Some(d) = &bench.demos {
        println!("demos:    {}", d.label);
    }
    println!();

    let mut rows = Vec::new();
    for figure in &selected {
        bench.note(&format!("running {figure} ..."));
        let t = Instant::now();
        let new = match *figure {
            "mujoco" => bench.mujoco()?,
            "dtw-batch" => bench.dtw_batch()?,
            "dtw-push" => bench.dtw_push()?,
            "filter" => bench.filter()?,
            "sac" => bench.training(Algo::Sac)?,
            "td3" => bench.training(Algo::Td3)?,
            "overhead" => bench.overhead()?,
            "dynamics" => bench.dynamics()?,
            other => bail!("internal: figure '{other}' has no measurement"),
        };
        bench.note(&format!("{figure} done in {:.1} s", t.elapsed().as_secs_f64()));
        rows.extend(new);
    }

    print!("{}", table(&rows));
    let with_target: Vec<&Row> = rows.iter().filter(|r| r.target.is_some()).collect();
    let missed: Vec<String> =
        with_target.iter().filter(|r| !r.met().unwrap_or(true)).map(|r| r.short()).collect();
    println!();
    println!("targets met: {} of {}", with_target.len() - missed.len(), with_target.len());
    for m in &missed {
        println!("  not met: {m}");
    }
    println!("load average {} at end; {:.0} s in total", load_average(), started.elapsed().as_secs_f64());
    Ok(())
}

/// Checks `--only` names and returns the figures to run, in their canonical order.
fn select(only: &[String]) -> anyhow::Result<Vec<&'static str>> {
    if only.is_empty() {
        return Ok(FIGURES.to_vec());
    }
    for name in only {
        let name = name.trim();
        if !FIGURES.contains(&name) {
            bail!(
                "--only: unknown figure '{name}' (expected a comma-separated list of: {})",
                FIGURES.join(", ")
            );
        }
    }
    Ok(FIGURES.iter().copied().filter(|f| only.iter().any(|n| n.trim() == *f)).collect())
}

// ---------------------------------------------------------------------------------------------
// The table.

#[derive(Debug, Clone, Copy)]
enum Target {
    AtLeast(f64),
    AtMost(f64),
}

impl Target {
    fn met(self, value: f64) -> bool {
        match self {
            Target::AtLeast(t) => value >= t,
            Target::AtMost(t) => value <= t,
        }
    }
    fn text(self) -> String {
        match self {
            Target::AtLeast(t) => format!(">= {t}"),
            Target::AtMost(t) => format!("<= {t}"),
        }
    }
}

/// One line of the table.
#[derive(Debug)]
struct Row {
    figure: &'static str,
    what: String,
    value: f64,
    unit: &'static str,
    target: Option<Target>,
    notes: String,
}

impl Row {
    fn new(figure: &'static str, what: impl Into<String>, value: f64, unit: &'static str) -> Self {
        Self { figure, what: what.into(), value, unit, target: None, notes: String::new() }
    }
    fn target(mut self, target: Target) -> Self {
        self.target = Some(target);
        self
    }
    fn notes(mut self, notes: impl Into<String>) -> Self {
        self.notes = notes.into();
        self
    }
    fn met(&self) -> Option<bool> {
        self.target.map(|t| t.met(self.value))
    }
    fn short(&self) -> String {
        format!("{} {}", self.figure, self.what)
    }
}

/// A number with a precision that suits its size.
fn number(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a >= 1000.0 {
        format!("{v:.0}")
    } else if a >= 100.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

fn table(rows: &[Row]) -> String {
    let header = ["figure", "what", "value", "unit", "target", "status", "notes"];
    let cells: Vec<[String; 7]> = rows
        .iter()
        .map(|r| {
            [
                r.figure.to_string(),
                r.what.clone(),
                number(r.value),
                r.unit.to_string(),
                r.target.map_or("-".into(), Target::text),
                match r.met() {
                    None => "-".into(),
                    Some(true) => "met".into(),
                    Some(false) => "NOT MET".into(),
                },
                r.notes.clone(),
            ]
        })
        .collect();
    let width =
        |c: usize| cells.iter().map(|r| r[c].chars().count()).chain([header[c].len()]).max().unwrap_or(0);
    let w: Vec<usize> = (0..7).map(width).collect();
    let mut out = String::new();
    let mut line = |c: [&str; 7]| {
        let text = format!(
            "{:<w0$}  {:<w1$}  {:>w2$}  {:<w3$}  {:<w4$}  {:<w5$}  {}",
            c[0],
            c[1],
            c[2],
            c[3],
            c[4],
            c[5],
            c[6],
            w0 = w[0],
            w1 = w[1],
            w2 = w[2],
            w3 = w[3],
            w4 = w[4],
            w5 = w[5],
        );
        out.push_str(text.trim_end());
        out.push('\n');
    };
    line(header);
    let rule: Vec<String> = w.iter().map(|&n| "-".repeat(n)).collect();
    line([&rule[0], &rule[1], &rule[2], &rule[3], &rule[4], &rule[5], "-----"]);
    for r in &cells {
        line([&r[0], &r[1], &r[2], &r[3], &r[4], &r[5], &r[6]]);
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Machine context and timing helpers.

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".into())
}

fn machine() -> String {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let model = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split(':').nth(1))
            .map(|m| m.trim().to_string())
    });
    match model {
        Some(m) => format!("{cores} cores ({m})"),
        None => format!("{cores} cores"),
    }
}

/// CPU time of the whole process (all threads) so far, from /proc/self/stat (clock ticks of
/// 1/100 s); `None` where that file is not available.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => values[n / 2],
        n => 0.5 * (values[n / 2 - 1] + values[n / 2]),
    }
}

// ---------------------------------------------------------------------------------------------
// Demonstrations.

struct DemoSet {
    set: EpisodeSet,
    label: String,
}

fn synthetic_demos() -> anyhow::Result<DemoSet> {
    // Far from anything Hopper visits: the filter never fires, so every step of a training run
    // pays the environment step, the filter and the dynamics model's training (the upper bound of
    // the overhead). DTW's cost does not depend on values.
    let shape = WalkSet { per_group: DEMOS_PER_GROUP, unsafe_offset: UNSAFE_OFFSET, ..WalkSet::HOPPER };
    let len = shape.len;
    let meta = Meta {
        env_id: Some(TASK.into()),
        provenance: Some("defender bench (synthetic)".into()),
        ..Meta::default()
    };
    let set = shape.build(SEED, meta)?;
    Ok(DemoSet {
        set,
        label: format!(
            "synthetic Hopper-shaped: {DEMOS_PER_GROUP} safe + {DEMOS_PER_GROUP} unsafe smooth random walks of \
             {len} steps, obs 11-D, act 3-D; unsafe ones offset by +{UNSAFE_OFFSET} so the filter never fires \
             (worst case: every step is real)"
        ),
    })
}

fn file_demos(path: &Path) -> anyhow::Result<DemoSet> {
    let set =
        EpisodeSet::load(path).with_context(|| format!("{}: loading demonstrations", path.display()))?;
    set.check_env(TASK, 11, 3).with_context(|| format!("{}: demonstrations for {TASK}", path.display()))?;
    let (safe, unsafe_) = set.group_sizes();
    if safe == 0 || unsafe_ == 0 {
        bail!("{}: {safe} safe and {unsafe_} unsafe demonstrations (both groups are needed)", path.display());
    }
    let n = DEMOS_PER_GROUP.min(safe).min(unsafe_);
    let set = set.select_demos(n)?;
    let lens: Vec<usize> = set.episodes().map(|e| e.len()).collect();
    let mean = lens.iter().sum::<usize>() as f64 / lens.len().max(1) as f64;
    let label = format!(
        "{}: first {n} safe + {n} unsafe of {safe} + {unsafe_}, mean length {mean:.0} steps",
        path.display()
    );
    Ok(DemoSet { set, label })
}

fn load_demos(path: Option<&Path>, synthetic: bool) -> anyhow::Result<DemoSet> {
    if synthetic {
        return synthetic_demos();
    }
    if let Some(path) = path {
        return file_demos(path);
    }
    let default = Path::new(DEFAULT_DEMOS);
    if default.exists() {
        match file_demos(default) {
            Ok(d) => return Ok(d),
            Err(err) => eprintln!("warning: {err:#}; using synthetic demonstrations"),
        }
    }
    synthetic_demos()
}

// ---------------------------------------------------------------------------------------------
// Training runs.

/// The dynamics model's schedule in a DEFENDER run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Schedule {
    /// The default (`DynamicsConfig::default()`).
    Default,
    /// SPEC section 5's: one gradient step on a batch of 256 per real step.
    Spec,
    /// Never trained (`train_freq` = 10^9): the filter and the wrapper alone.
    Untrained,
    /// SPEC's, trained on the model's own thread while the agent updates.
    SpecBackground,
}

impl Schedule {
    fn config(self) -> DynamicsConfig {
        let spec = DynamicsConfig::spec_schedule();
        match self {
            Schedule::Default => DynamicsConfig::default(),
            Schedule::Spec => spec,
            Schedule::Untrained => DynamicsConfig { train_freq: 1_000_000_000, ..spec },
            Schedule::SpecBackground => DynamicsConfig { background: true, ..spec },
        }
    }
    fn text(self) -> String {
        let d = DynamicsConfig::default();
        match self {
            Schedule::Default => format!(
                "dynamics model as default ({} step(s) of batch {} every {} real steps)",
                d.gradient_steps, d.batch_size, d.train_freq
            ),
            Schedule::Spec => "dynamics model as SPEC (batch 256 every real step)".into(),
            Schedule::Untrained => "dynamics model not trained".into(),
            Schedule::SpecBackground => "dynamics model as SPEC, on its own thread".into(),
        }
    }
}

/// A training run: bare SAC or TD3, or SAC on `DefenderEnv`.
#[derive(Debug, Clone, PartialEq)]
enum RunKind {
    Bare(Algo),
    Defender { strategy: Strategy, mode: Mode, schedule: Schedule },
}

/// The timed steps of one training run.
#[derive(Debug, Clone, Copy)]
struct Timing {
    seconds: f64,
    cpu_seconds: Option<f64>,
    steps: u64,
    episodes: u64,
    filtered: u64,
}

impl Timing {
    fn ms_per_step(&self) -> f64 {
        self.seconds * 1e3 / self.steps as f64
    }
    fn cores(&self) -> String {
        self.cpu_seconds.map_or(String::new(), |c| format!("; CPU {:.2} cores", c / self.seconds))
    }
}

/// Times a training run step by step, in segments: it asks the trainer to stop at the first
/// episode boundary after `stop_at` steps, so that several runs can take turns and see the same
/// machine load. A step is timed from the end of the previous step to its own end (the agent's
/// action, the environment step, the update and any reset in between); the first step of each
/// segment and the warm-up steps (up to `learning_starts`) are not timed.
struct SegmentClock {
    learning_starts: u64,
    total: u64,
    stop_at: u64,
    steps_seen: u64,
    last: Option<Instant>,
    cpu_start: Option<f64>,
    cpu_ok: bool,
    timing: Timing,
}

impl SegmentClock {
    fn new(learning_starts: u64, total: u64) -> Self {
        Self {
            learning_starts,
            total,
            stop_at: 0,
            steps_seen: 0,
            last: None,
            cpu_start: None,
            cpu_ok: true,
            timing: Timing { seconds: 0.0, cpu_seconds: Some(0.0), steps: 0, episodes: 0, filtered: 0 },
        }
    }

    fn done(&self) -> bool {
        self.steps_seen >= self.total
    }

    fn end_segment(&mut self) {
        if self.last.take().is_some() {
            match (self.cpu_start.take(), process_cpu_seconds(), self.timing.cpu_seconds.as_mut()) {
                (Some(a), Some(b), Some(sum)) if self.cpu_ok => *sum += b - a,
                _ => self.cpu_ok = false,
            }
        }
    }

    fn timing(&self) -> Timing {
        Timing { cpu_seconds: self.timing.cpu_seconds.filter(|_| self.cpu_ok), ..self.timing }
    }
}

impl Hooks for SegmentClock {
    fn on_step(&mut self, total_steps: u64) {
        self.steps_seen = total_steps;
        if total_steps < self.learning_starts {
            return;
        }
        let now = Instant::now();
        match self.last {
            Some(last) => {
                self.timing.seconds += (now - last).as_secs_f64();
                self.timing.steps += 1;
            }
            None => self.cpu_start = process_cpu_seconds(),
        }
        self.last = Some(now);
        if total_steps >= self.total {
            self.end_segment();
        }
    }
    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        if record.total_steps > self.learning_starts {
            self.timing.episodes += 1;
            // A filtered episode ends on its one filtered step.
            self.timing.filtered += u64::from(record.filtered);
        }
        Ok(())
    }
    fn should_stop(&mut self) -> bool {
        let stop = self.steps_seen >= self.stop_at && !self.done();
        if stop {
            self.end_segment();
        }
        stop
    }
}

type AnyTrainer = Trainer<Box<dyn Agent>, Box<dyn Env>, TimeLimit<MujocoEnv>>;

/// Runs the trainers in turns of about `segment` steps each until all have spent their budget.
fn take_turns(runs: &mut [(AnyTrainer, SegmentClock)], segment: u64) -> anyhow::Result<()> {
    loop {
        let mut active = false;
        for (trainer, clock) in runs.iter_mut() {
            if clock.done() {
                continue;
            }
            active = true;
            clock.stop_at = clock.steps_seen.max(clock.learning_starts) + segment;
            trainer.run(clock)?;
        }
        if !active {
            return Ok(());
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The measurements.

struct Bench {
    quick: bool,
    steps: u64,
    par: Parallelism,
    demos: Option<DemoSet>,
    selected: Vec<&'static str>,
    /// The interleaved training runs of `overhead` and `dynamics`, once made.
    contest: Option<Vec<(RunKind, u8, Timing)>>,
    progress: bool,
}

impl Bench {
    fn note(&self, text: &str) {
        if self.progress {
            eprintln!("bench: {text}");
        }
    }

    fn demos(&self) -> anyhow::Result<&DemoSet> {
        self.demos.as_ref().context("internal: demonstrations were not loaded")
    }

    /// Environment steps per second, random actions (precomputed), reset when an episode ends.
    fn mujoco(&mut self) -> anyhow::Result<Vec<Row>> {
        let (steps, reps) = if self.quick { (2_000, 2) } else { (5_000, 3) };
        let mut rows = Vec::new();
        for spec in defender_mujoco::registry() {
            let mut env = defender_mujoco::make(spec.id)?;
            let space = env.action_space().clone();
            let mut rng = ChaCha8Rng::seed_from_u64(SEED);
            let actions: Vec<Vec<f64>> = (0..4096)
                .map(|_| {
                    space.low().iter().zip(space.high()).map(|(&l, &h)| rng.random_range(l..=h)).collect()
                })
                .collect();
            let mut episode = 0u64;
            env.reset(Some(episode))?;
            let mut i = 0usize;
            let mut run = |n: usize| -> anyhow::Result<f64> {
                let t = Instant::now();
                for _ in 0..n {
                    let step = env.step(&actions[i % actions.len()])?;
                    i += 1;
                    if step.done() {
                        episode += 1;
                        env.reset(Some(episode))?;
                    }
                }
                Ok(n as f64 / t.elapsed().as_secs_f64())
            };
            run(500)?; // warm-up
            let mut best = 0.0f64;
            for _ in 0..reps {
                best = best.max(run(steps)?);
            }
            let mut row =
                Row::new("mujoco", format!("{} env steps, random actions", spec.id), best, "steps/s").notes(
                    format!("best of {reps} x {steps} steps, resets included; {:.1} us/step", 1e6 / best),
                );
            if spec.id == "Hopper-v5" {
                row = row.target(Target::AtLeast(5000.0));
            }
            rows.push(row);
        }
        Ok(rows)
    }

    fn dtw_batch(&mut self) -> anyhow::Result<Vec<Row>> {
        let (n, m, d) = (1000, 1000, 11);
        let mut rng = ChaCha8Rng::seed_from_u64(SEED);
        let (x, _) = walk(&mut rng, n - 1, d, 1);
        let (y, _) = walk(&mut rng, m - 1, d, 1);
        let settings = Dtw::euclidean();
        let reps = if self.quick { 10 } else { 30 };
        for _ in 0..3 {
            std::hint::black_box(dtw(&x, &y, d, &settings)?);
        }
        let mut best = f64::INFINITY;
        for _ in 0..reps {
            let t = Instant::now();
            std::hint::black_box(dtw(&x, &y, d, &settings)?);
            best = best.min(t.elapsed().as_secs_f64());
        }
        let cells = (n * m) as f64;
        Ok(vec![
            Row::new(
                "dtw-batch",
                "batch DTW 1000 x 1000, d = 11 (Euclidean)",
                cells / best / 1e6,
                "M cells/s",
            )
            .target(Target::AtLeast(500.0))
            .notes(format!("best of {reps}: {:.3} ms", best * 1e3)),
        ])
    }

    fn dtw_push(&mut self) -> anyhow::Result<Vec<Row>> {
        let (count, m, d) = (100, 1000, 11);
        let mut rng = ChaCha8Rng::seed_from_u64(SEED);
        let seqs: Vec<Vec<f32>> = (0..count).map(|_| walk(&mut rng, m - 1, d, 1).0).collect();
        let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
        let refs = References::new(d, &slices)?;
        let (query, _) = walk(&mut rng, m - 1, d, 1);
        let mut stream = refs.stream(&[View::new(QueryWindow::All, RefWindow::All)])?;
        let episodes = if self.quick { 2 } else { 4 };
        let mut best = f64::INFINITY;
        for e in 0..=episodes {
            stream.reset();
            let t = Instant::now();
            for xt in query.chunks_exact(d) {
                stream.push(xt)?;
            }
            let per_push = t.elapsed().as_secs_f64() / m as f64;
            if e > 0 {
                best = best.min(per_push); // episode 0 is the warm-up
            }
        }
        Ok(vec![
            Row::new("dtw-push", "one push, 100 refs x 1000, d = 11, (All, All)", best * 1e6, "us")
                .target(Target::AtMost(200.0))
                .notes(format!("best of {episodes} episodes of {m} pushes (mean per push)")),
        ])
    }

    fn filter(&mut self) -> anyhow::Result<Vec<Row>> {
        let demos = self.demos()?;
        let (obs_dim, act_dim, len) = (demos.set.obs_dim(), demos.set.act_dim(), 1000);
        let mut rng = ChaCha8Rng::seed_from_u64(SEED + 1);
        let (obs, act) = walk(&mut rng, len, obs_dim, act_dim);
        let obs: Vec<f64> = obs.iter().map(|&v| f64::from(v)).collect();
        let act: Vec<f64> = act.iter().map(|&v| f64::from(v)).collect();
        let episodes = if self.quick { 1 } else { 3 };
        let cases: [(&str, Mode, f64); 4] = [
            ("MeanDemoW5/MeanDemoW10", Mode::State, 10.0),
            ("MeanBothW5/MeanBothW5", Mode::State, 10.0),
            ("MinBoth/MinTrajW10", Mode::State, 2000.0),
            ("MinBoth/MinTrajW10", Mode::StateAction, 2000.0),
        ];
        let mut rows = Vec::new();
        for (name, mode, target) in cases {
            let strategy: Strategy = name.parse()?;
            let prepared = Demonstrations::new(&demos.set, mode, CostOptions::default())?;
            let mut filter = Filter::new(&prepared, strategy)?;
            let mut times = Vec::with_capacity(episodes * len);
            let mut filtered = 0usize;
            for e in 0..=episodes {
                filter.reset();
                for t in 0..len {
                    let (s, a) = (&obs[t * obs_dim..(t + 1) * obs_dim], &act[t * act_dim..(t + 1) * act_dim]);
                    let start = Instant::now();
                    let decision = std::hint::black_box(filter.push(s, a)?);
                    let us = start.elapsed().as_secs_f64() * 1e6;
                    if e > 0 {
                        times.push(us); // episode 0 is the warm-up
                        filtered += usize::from(decision.filtered);
                    }
                }
            }
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            let med = median(&mut times);
            rows.push(
                Row::new("filter", format!("{strategy} ({mode}) per step"), med, "us")
                    .target(Target::AtMost(target))
                    .notes(format!(
                        "median of {episodes} x {len} steps (mean {}); a whole episode pushed, {} of the \
                         decisions filter",
                        number(mean),
                        filtered / episodes
                    )),
            );
        }
        Ok(rows)
    }

    fn agent(&self, algo: Algo, obs_dim: usize, act_dim: usize) -> anyhow::Result<Box<dyn Agent>> {
        Ok(match algo {
            Algo::Sac => {
                let config = SacConfig { learning_starts: LEARNING_STARTS, ..SacConfig::default() };
                let mut agent = Sac::new(config, obs_dim, act_dim, SEED)?;
                agent.set_parallelism(self.par);
                Box::new(agent)
            }
            Algo::Td3 => {
                let config = Td3Config { learning_starts: LEARNING_STARTS, ..Td3Config::default() };
                let mut agent = Td3::new(config, obs_dim, act_dim, SEED)?;
                agent.set_parallelism(self.par);
                Box::new(agent)
            }
        })
    }

    /// A fresh trainer for `kind` (seed 0, `LEARNING_STARTS` + `steps` steps) and its clock.
    fn trainer(&self, kind: &RunKind) -> anyhow::Result<(AnyTrainer, SegmentClock)> {
        let env = defender_mujoco::make(TASK)?;
        let (obs_dim, act_dim) = (env.observation_space().dim(), env.action_space().dim());
        let (agent, env): (Box<dyn Agent>, Box<dyn Env>) = match kind {
            RunKind::Bare(algo) => (self.agent(*algo, obs_dim, act_dim)?, Box::new(env)),
            RunKind::Defender { strategy, mode, schedule } => {
                let config = DefenderConfig {
                    strategy: *strategy,
                    mode: *mode,
                    dynamics: schedule.config(),
                    ..DefenderConfig::default()
                };
                let mut rng = ChaCha8Rng::seed_from_u64(SEED);
                let background = config.dynamics.background;
                let env = DefenderEnv::new(env, &self.demos()?.set, config, &mut rng)?;
                if !background {
                    // In the background the model has its own thread and stays sequential.
                    env.dynamics()?.set_parallelism(self.par);
                }
                (self.agent(Algo::Sac, obs_dim, act_dim)?, Box::new(env))
            }
        };
        let total = LEARNING_STARTS + self.steps;
        let config =
            TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(SEED, Budget::Steps(total)) };
        let trainer = Trainer::new(agent, env, defender_mujoco::make(TASK)?, config)?;
        Ok((trainer, SegmentClock::new(LEARNING_STARTS, total)))
    }

    fn training(&mut self, algo: Algo) -> anyhow::Result<Vec<Row>> {
        self.note(&format!("{} training run, {LEARNING_STARTS} + {} steps", algo.as_str(), self.steps));
        let mut runs = vec![self.trainer(&RunKind::Bare(algo))?];
        take_turns(&mut runs, u64::MAX / 4)?; // one turn: the whole run
        let t = runs[0].1.timing();
        let (name, target) = match algo {
            Algo::Sac => ("SAC", 150.0),
            Algo::Td3 => ("TD3", 200.0),
        };
        Ok(vec![
            Row::new(
                algo.as_str(),
                format!("{name} training on {TASK}, env step + one update"),
                t.steps as f64 / t.seconds,
                "steps/s",
            )
            .target(Target::AtLeast(target))
            .notes(format!(
                "{} timed steps, {:.2} ms/step, {} network thread(s){}",
                t.steps,
                t.ms_per_step(),
                self.par.num_threads(),
                t.cores()
            )),
        ])
    }

    /// The training runs behind `overhead` and `dynamics`, made once for both and interleaved
    /// (turns of about `steps / 8` steps) so that every run sees the same machine load: two
    /// identical bare SAC runs (their ratio is the noise floor) and the DEFENDER runs.
    fn contest(&mut self) -> anyhow::Result<Vec<(RunKind, u8, Timing)>> {
        if let Some(done) = &self.contest {
            return Ok(done.clone());
        }
        let mut kinds: Vec<(RunKind, u8)> =
            vec![(RunKind::Bare(Algo::Sac), 0), (RunKind::Bare(Algo::Sac), 1)];
        let mut add = |kind: RunKind| {
            if !kinds.iter().any(|(k, _)| *k == kind) {
                kinds.push((kind, 0));
            }
        };
        if self.selected.contains(&"overhead") {
            for (name, mode, _) in OVERHEAD_CASES {
                add(RunKind::Defender { strategy: name.parse()?, mode, schedule: Schedule::Default });
            }
        }
        if self.selected.contains(&"dynamics") {
            for schedule in SCHEDULES {
                add(RunKind::Defender { strategy: DYNAMICS_STRATEGY.parse()?, mode: Mode::State, schedule });
            }
        }
        let segment = (self.steps / 8).max(50);
        self.note(&format!(
            "{} interleaved training runs of {LEARNING_STARTS} + {} steps, turns of {segment} steps",
            kinds.len(),
            self.steps
        ));
        let mut runs = Vec::with_capacity(kinds.len());
        for (kind, _) in &kinds {
            runs.push(self.trainer(kind)?);
        }
        take_turns(&mut runs, segment)?;
        let done: Vec<(RunKind, u8, Timing)> =
            kinds.into_iter().zip(&runs).map(|((k, r), (_, clock))| (k, r, clock.timing())).collect();
        self.contest = Some(done.clone());
        Ok(done)
    }

    fn overhead(&mut self) -> anyhow::Result<Vec<Row>> {
        let runs = self.contest()?;
        let (bare_ms, mut rows) = bare_rows(&runs, "overhead")?;
        for (name, mode, target) in OVERHEAD_CASES {
            let kind = RunKind::Defender { strategy: name.parse()?, mode, schedule: Schedule::Default };
            let t = find(&runs, &kind, 0)?;
            rows.push(defender_row(
                "overhead",
                &t,
                bare_ms,
                format!("SAC + DEFENDER {name} ({mode})"),
                Some(target),
            ));
        }
        Ok(rows)
    }

    /// Median time of one `DynamicsModel::observe` (held-out prediction, store, training as
    /// scheduled), and the mean (which amortises schedules that train every k steps).
    fn dynamics_step(&self, schedule: Schedule) -> anyhow::Result<(f64, f64)> {
        let (obs_dim, act_dim) = (11, 3);
        let mut rng = ChaCha8Rng::seed_from_u64(SEED);
        let mut model = DynamicsModel::new(obs_dim, act_dim, schedule.config(), &mut rng)?;
        model.set_parallelism(self.par);
        let (warm, timed) = if self.quick { (300, 300) } else { (300, 1000) };
        let (obs, act) = walk(&mut rng, warm + timed, obs_dim, act_dim);
        let obs: Vec<f64> = obs.iter().map(|&v| f64::from(v)).collect();
        let act: Vec<f64> = act.iter().map(|&v| f64::from(v)).collect();
        let mut times = Vec::with_capacity(timed);
        for t in 0..warm + timed {
            let (s, a) = (&obs[t * obs_dim..(t + 1) * obs_dim], &act[t * act_dim..(t + 1) * act_dim]);
            let next = &obs[(t + 1) * obs_dim..(t + 2) * obs_dim];
            let start = Instant::now();
            model.observe(s, a, next)?;
            if t >= warm {
                times.push(start.elapsed().as_secs_f64() * 1e6);
            }
        }
        let mean = times.iter().sum::<f64>() / times.len() as f64;
        Ok((median(&mut times), mean))
    }

    fn dynamics(&mut self) -> anyhow::Result<Vec<Row>> {
        let mut rows = Vec::new();
        for (schedule, what) in [
            (Schedule::Spec, "dynamics model, one real step (SPEC: batch 256, 1 Adam step)"),
            (Schedule::Default, "dynamics model, one real step (default schedule)"),
        ] {
            let (med, mean) = self.dynamics_step(schedule)?;
            let (value, how) = match schedule {
                Schedule::Default => (mean, format!("mean over the steps (median {})", number(med))),
                _ => (med, format!("median (mean {})", number(mean))),
            };
            rows.push(
                Row::new("dynamics", what, value, "us")
                    .notes(format!("{how}; predict + store + train, {} thread(s)", self.par.num_threads())),
            );
        }
        let runs = self.contest()?;
        let (bare_ms, bare) = bare_rows(&runs, "dynamics")?;
        if !self.selected.contains(&"overhead") {
            rows.extend(bare);
        }
        let strategy: Strategy = DYNAMICS_STRATEGY.parse()?;
        let kind = |schedule| RunKind::Defender { strategy, mode: Mode::State, schedule };
        let mut pct = Vec::new();
        for schedule in SCHEDULES {
            let t = find(&runs, &kind(schedule), 0)?;
            pct.push(t.ms_per_step() / bare_ms * 100.0);
            let target = match schedule {
                Schedule::Untrained | Schedule::Spec => None,
                Schedule::Default | Schedule::SpecBackground => Some(105.0),
            };
            let what = format!("SAC + DEFENDER {strategy}, {}", schedule.text());
            rows.push(defender_row("dynamics", &t, bare_ms, what, target));
        }
        let (spec, untrained, default) = (pct[0], pct[1], pct[2]);
        for (name, full) in [("SPEC's schedule", spec), ("the default schedule", default)] {
            let share = if full > 100.0 {
                format!("{:.0}%", 100.0 * (full - untrained) / (full - 100.0))
            } else {
                "-".into()
            };
            rows.push(
                Row::new(
                    "dynamics",
                    format!("dynamics model training in {strategy}'s % Time, {name}"),
                    full - untrained,
                    "points",
                )
                .notes(format!(
                    "% Time {full:.1} trained vs {untrained:.1} not trained: {share} of the overhead"
                )),
            );
        }
        Ok(rows)
    }
}

/// The strategies of the `overhead` figure (the paper's Table 1 state strategies, in both
/// modes) and their % Time targets, with DEFENDER's default settings.
const OVERHEAD_CASES: [(&str, Mode, f64); 6] = [
    ("MeanDemoW5/MeanDemoW10", Mode::State, 105.0),
    ("MeanBothW5/MeanBothW5", Mode::State, 105.0),
    ("MinDemoW5/MinDemoW10", Mode::State, 105.0),
    ("MeanDemoW5/MeanDemoW10", Mode::StateAction, 115.0),
    ("MeanBothW5/MeanBothW5", Mode::StateAction, 115.0),
    ("MinDemoW5/MinDemoW10", Mode::StateAction, 115.0),
];

/// The strategy and the dynamics-model schedules of the `dynamics` figure (`dynamics` reads
/// the first three in this order).
const DYNAMICS_STRATEGY: &str = "MeanDemoW5/MeanDemoW10";
const SCHEDULES: [Schedule; 4] =
    [Schedule::Spec, Schedule::Untrained, Schedule::Default, Schedule::SpecBackground];

fn find(runs: &[(RunKind, u8, Timing)], kind: &RunKind, replica: u8) -> anyhow::Result<Timing> {
    runs.iter()
        .find(|(k, r, _)| k == kind && *r == replica)
        .map(|(_, _, t)| *t)
        .with_context(|| format!("internal: no training run {kind:?} #{replica}"))
}

/// The reference (mean ms/step of the two bare SAC runs) and its rows.
fn bare_rows(runs: &[(RunKind, u8, Timing)], figure: &'static str) -> anyhow::Result<(f64, Vec<Row>)> {
    let bare = RunKind::Bare(Algo::Sac);
    let (b0, b1) = (find(runs, &bare, 0)?, find(runs, &bare, 1)?);
    let bare_ms = 0.5 * (b0.ms_per_step() + b1.ms_per_step());
    let rows = vec![
        Row::new(figure, format!("SAC bare on {TASK} (the 100% reference)"), bare_ms, "ms/step").notes(
            format!(
                "mean of two identical runs: {:.2} and {:.2} ms/step, {} timed steps each{}",
                b0.ms_per_step(),
                b1.ms_per_step(),
                b0.steps,
                b0.cores()
            ),
        ),
        Row::new(
            figure,
            "SAC bare, second run over first (noise floor)",
            b1.ms_per_step() / b0.ms_per_step() * 100.0,
            "% Time",
        )
        .notes("same seed, same work: any distance from 100 is the machine's noise"),
    ];
    Ok((bare_ms, rows))
}

fn defender_row(figure: &'static str, t: &Timing, bare_ms: f64, what: String, target: Option<f64>) -> Row {
    let mut row = Row::new(figure, what, t.ms_per_step() / bare_ms * 100.0, "% Time").notes(format!(
        "{:.2} ms/step; {} of {} timed steps filtered ({:.0}%), {} episodes{}",
        t.ms_per_step(),
        t.filtered,
        t.steps,
        100.0 * t.filtered as f64 / t.steps.max(1) as f64,
        t.episodes,
        t.cores()
    ));
    if let Some(target) = target {
        row = row.target(Target::AtMost(target));
    }
    row
}
