//! `dynamics_schedules`: how the dynamics model's training schedule (train every k real steps,
//! g gradient steps, batch b) trades its prediction error for its cost, on the transitions of a
//! real run, in the order the run produced them.
//!
//! Usage: `cargo run --release -p defender --example dynamics_schedules -- EPISODES.npz [SEEDS]
//! [SCHEDULES]`, where EPISODES.npz is an episode set in training order (`defender train
//! --record-episodes`, or a demonstration set), SEEDS the number of model seeds (default 2) and
//! SCHEDULES a comma-separated list of `k:g:b` or `k:g:b:lr` (default: SPEC's `1:1:256` and
//! cheaper ones; the learning rate defaults to SPEC's 3e-4).
//!
//! Every 10th episode is held out; the model learns from the other episodes' transitions one
//! by one, through `DynamicsModel::observe`, as `DefenderEnv` feeds it. Reported per schedule
//! (mean over seeds; MSE over the observation's components, raw units, as the model tracks it):
//! - **held-out**: the MSE on the held-out episodes of the first half of the stream after learning
//!   the first half, and on those of the second half at the end, averaged: the error on
//!   transitions the model never saw, from the policy of the time;
//! - **online**: the mean error of each fresh transition predicted before learning from it (what
//!   a filtered step gets), over the last 90% of the stream;
//! - **cost**: the thread CPU time of `observe` per real transition (one thread).

#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: fail loudly

use std::time::Instant;

use defender::{DynamicsConfig, DynamicsModel, EpisodeSet};
use defender_nn::Parallelism;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const HOLDOUT_EVERY: usize = 10;
const DEFAULT_SCHEDULES: &str = "1:1:256,2:1:256,4:1:256,8:1:256,1:1:64,2:1:128,4:1:128,4:1:64,8:2:128";

/// One transition `(s, a, s')` in f64.
type Transition = (Vec<f64>, Vec<f64>, Vec<f64>);

fn transitions(set: &EpisodeSet, episodes: impl Iterator<Item = usize>) -> Vec<Transition> {
    let (o, a) = (set.obs_dim(), set.act_dim());
    let mut out = Vec::new();
    for i in episodes {
        let ep = set.episode(i);
        let n = ep.rew.len();
        for t in 0..n {
            let f = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
            out.push((
                f(&ep.obs[t * o..(t + 1) * o]),
                f(&ep.act[t * a..(t + 1) * a]),
                f(&ep.obs[(t + 1) * o..(t + 2) * o]),
            ));
        }
    }
    out
}

fn held_out_mse(m: &mut DynamicsModel, data: &[Transition]) -> f64 {
    let mut pred = vec![0.0; m.obs_dim()];
    let mut total = 0.0;
    for (s, a, next) in data {
        m.predict_into(s, a, &mut pred).unwrap();
        total += pred.iter().zip(next).map(|(p, n)| (p - n).powi(2)).sum::<f64>() / pred.len() as f64;
    }
    total / data.len().max(1) as f64
}

/// CPU time of the calling thread in seconds (Linux), for a loaded machine.
fn thread_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(text.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
}

struct Outcome {
    held_out: f64,
    online: f64,
    cpu_us: f64,
    wall_us: f64,
    gradient_steps: u64,
    real_steps: u64,
}

fn run(set: &EpisodeSet, schedule: (usize, usize, usize, f32), seed: u64) -> Outcome {
    let n = set.len();
    let half = n / 2;
    let held = |r: std::ops::Range<usize>| r.filter(|i| i % HOLDOUT_EVERY == HOLDOUT_EVERY - 1);
    let learn = |r: std::ops::Range<usize>| r.filter(|i| i % HOLDOUT_EVERY != HOLDOUT_EVERY - 1);
    let (train1, train2) = (transitions(set, learn(0..half)), transitions(set, learn(half..n)));
    let (test1, test2) = (transitions(set, held(0..half)), transitions(set, held(half..n)));
    let (k, g, b, learning_rate) = schedule;
    let config = DynamicsConfig {
        train_freq: k,
        gradient_steps: g,
        batch_size: b,
        learning_rate,
        ..DynamicsConfig::spec_schedule()
    };
    let mut model =
        DynamicsModel::new(set.obs_dim(), set.act_dim(), config, &mut ChaCha8Rng::seed_from_u64(seed))
            .unwrap();
    model.set_parallelism(Parallelism::Sequential);
    let total = train1.len() + train2.len();
    let skip = total / 10;
    let (mut online, mut online_n, mut seen) = (0.0, 0usize, 0usize);
    let (mut cpu, mut wall) = (0.0, 0.0);
    let mut held_out = 0.0;
    for (part, test) in [(&train1, &test1), (&train2, &test2)] {
        for (s, a, next) in part.iter() {
            let (c0, w0) = (thread_cpu_seconds(), Instant::now());
            model.observe(s, a, next).unwrap();
            wall += w0.elapsed().as_secs_f64();
            if let (Some(c0), Some(c1)) = (c0, thread_cpu_seconds()) {
                cpu += c1 - c0;
            }
            seen += 1;
            if seen > skip {
                online += model.prediction_error().last;
                online_n += 1;
            }
        }
        held_out += 0.5 * held_out_mse(&mut model, test);
    }
    Outcome {
        held_out,
        online: online / online_n.max(1) as f64,
        cpu_us: cpu / total as f64 * 1e6,
        wall_us: wall / total as f64 * 1e6,
        gradient_steps: model.gradient_steps(),
        real_steps: model.real_steps(),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: dynamics_schedules EPISODES.npz [SEEDS] [k:g:b,...]");
        std::process::exit(2);
    };
    let seeds: u64 = args.get(2).map_or(2, |s| s.parse().expect("SEEDS: a number"));
    let schedules: Vec<(usize, usize, usize, f32)> = args
        .get(3)
        .map_or(DEFAULT_SCHEDULES, String::as_str)
        .split(',')
        .map(|s| {
            let v: Vec<&str> = s.split(':').collect();
            let n = |i: usize| v[i].parse::<usize>().expect("k:g:b[:lr]");
            (n(0), n(1), n(2), v.get(3).map_or(3e-4, |lr| lr.parse().expect("lr")))
        })
        .collect();
    let set = EpisodeSet::load(path).unwrap();
    println!(
        "{path}: {} episodes, {} transitions (every {HOLDOUT_EVERY}th episode held out), obs {} act {}, {seeds} seed(s)",
        set.len(),
        set.transitions(),
        set.obs_dim(),
        set.act_dim()
    );
    println!(
        "| k:g:b | gradient steps per real step | cost, CPU us per real step | held-out MSE | vs SPEC | online MSE | vs SPEC | per-seed held-out |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    let mut reference: Option<(f64, f64)> = None;
    for &(k, g, b, lr) in &schedules {
        let outs: Vec<Outcome> = (0..seeds).map(|seed| run(&set, (k, g, b, lr), seed)).collect();
        let mean = |f: &dyn Fn(&Outcome) -> f64| outs.iter().map(f).sum::<f64>() / outs.len() as f64;
        let (held, online, cpu, wall) =
            (mean(&|o| o.held_out), mean(&|o| o.online), mean(&|o| o.cpu_us), mean(&|o| o.wall_us));
        let (rh, ro) = *reference.get_or_insert((held, online));
        let per_seed: Vec<String> = outs.iter().map(|o| format!("{:.4}", o.held_out)).collect();
        println!(
            "| {k}:{g}:{b}:{lr:e} | {:.3} | {cpu:.0} (wall {wall:.0}) | {held:.4} | {:.1}% | {online:.4} | {:.1}% | {} |",
            outs[0].gradient_steps as f64 / outs[0].real_steps as f64,
            100.0 * held / rh,
            100.0 * online / ro,
            per_seed.join(", ")
        );
    }
}
