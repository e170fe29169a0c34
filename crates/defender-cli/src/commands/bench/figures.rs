//! The measurements: MuJoCo steps, training steps, DEFENDER's overhead and the dynamics model's
//! share of it. DTW and filter micro-figures live in the crates' criterion benches
//! (`cargo bench -p defender-dtw`, `cargo bench -p defender --bench filter`).

use std::time::Instant;

use anyhow::Context;
use defender::synthetic::random_walk as walk;
use defender::{DefenderConfig, DefenderEnv, DynamicsModel, Mode, Strategy};
use defender_rl::{
    Agent, Algo, Budget, Env, Parallelism, Sac, SacConfig, Td3, Td3Config, Trainer, TrainerConfig,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::clock::{AnyTrainer, SegmentClock, Timing, take_turns};
use super::demos::DemoSet;
use super::machine::median;
use super::row::{Row, Target, number};
use super::runs::{RunKind, Schedule};
use super::{Figure, LEARNING_STARTS, SEED, TASK};

// ---------------------------------------------------------------------------------------------
// The measurements.

pub(super) struct Bench {
    pub(super) quick: bool,
    pub(super) steps: u64,
    pub(super) par: Parallelism,
    pub(super) demos: Option<DemoSet>,
    pub(super) selected: Vec<Figure>,
    /// The interleaved training runs of `overhead` and `dynamics`, once made.
    pub(super) contest: Option<Vec<(RunKind, u8, Timing)>>,
    pub(super) progress: bool,
}

impl Bench {
    pub(super) fn note(&self, text: &str) {
        if self.progress {
            note!("bench: {text}");
        }
    }

    fn demos(&self) -> anyhow::Result<&DemoSet> {
        self.demos.as_ref().context("internal: demonstrations were not loaded")
    }

    /// Environment steps per second, random actions (precomputed), reset when an episode ends.
    pub(super) fn mujoco(&mut self) -> anyhow::Result<Vec<Row>> {
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
            let mut row = Row::new(
                Figure::Mujoco.name(),
                format!("{} env steps, random actions", spec.id),
                best,
                "steps/s",
            )
            .notes(format!("best of {reps} x {steps} steps, resets included; {:.1} us/step", 1e6 / best));
            if spec.id == "Hopper-v5" {
                row = row.target(Target::AtLeast(5000.0));
            }
            rows.push(row);
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
                    dynamics: schedule.config(self.par),
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

    pub(super) fn training(&mut self, algo: Algo) -> anyhow::Result<Vec<Row>> {
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
        if self.selected.contains(&Figure::Overhead) {
            for (name, mode, _) in OVERHEAD_CASES {
                add(RunKind::Defender { strategy: name.parse()?, mode, schedule: Schedule::Default });
            }
        }
        if self.selected.contains(&Figure::Dynamics) {
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

    pub(super) fn overhead(&mut self) -> anyhow::Result<Vec<Row>> {
        let runs = self.contest()?;
        let (bare_ms, mut rows) = bare_rows(&runs, Figure::Overhead.name())?;
        for (name, mode, target) in OVERHEAD_CASES {
            let kind = RunKind::Defender { strategy: name.parse()?, mode, schedule: Schedule::Default };
            let t = find(&runs, &kind, 0)?;
            rows.push(defender_row(
                Figure::Overhead.name(),
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
        let mut model = DynamicsModel::new(obs_dim, act_dim, schedule.config(self.par), &mut rng)?;
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

    pub(super) fn dynamics(&mut self) -> anyhow::Result<Vec<Row>> {
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
                Row::new(Figure::Dynamics.name(), what, value, "us")
                    .notes(format!("{how}; predict + store + train, {} thread(s)", self.par.num_threads())),
            );
        }
        let runs = self.contest()?;
        let (bare_ms, bare) = bare_rows(&runs, Figure::Dynamics.name())?;
        if !self.selected.contains(&Figure::Overhead) {
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
                Schedule::Default | Schedule::SpecBackground | Schedule::DefaultInline => Some(105.0),
            };
            let what = format!("SAC + DEFENDER {strategy}, {}", schedule.text());
            rows.push(defender_row(Figure::Dynamics.name(), &t, bare_ms, what, target));
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
                    Figure::Dynamics.name(),
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
const SCHEDULES: [Schedule; 5] = [
    Schedule::Spec,
    Schedule::Untrained,
    Schedule::Default,
    Schedule::SpecBackground,
    Schedule::DefaultInline,
];

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
