//! The online filter, the dynamics model and the ablation on Hopper-v5-shaped data.
//!
//! The data are synthetic trajectories of Hopper's shape (`defender::synthetic`, so that the
//! figures do not depend on a particular trained agent): smooth random walks (velocity with momentum) in 11 dimensions, 50 safe and 50
//! unsafe demonstrations of 1000 transitions each (1001 observations, the longest Hopper allows),
//! and a 1000-step agent episode. DTW cost depends only on shapes, not on values, except for
//! the `Equal` window, which this bench does not use.
//!
//! `cargo bench -p defender --bench filter` (one core: the filter is single-threaded). The time of
//! each step along the episode (constant for every window but `Equal`) is shown by
//! `cargo run --release -p defender --example filter_steps`.

#![allow(clippy::unwrap_used)] // test and bench helpers fail loudly on purpose

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use defender::{
    Ablation, CostOptions, Demonstrations, DynamicsConfig, DynamicsModel, EpisodeSet, Filter, Meta, Mode,
    Strategy,
    synthetic::{WalkSet, random_walk},
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

const OBS: usize = 11;
const ACT: usize = 3;

/// 2 x `per_group` demonstrations of `len` transitions, safe and unsafe alike.
fn demos(seed: u64, per_group: usize, len: usize) -> EpisodeSet {
    WalkSet { obs_dim: OBS, act_dim: ACT, per_group, len, unsafe_offset: 0.0 }
        .build(seed, Meta::default())
        .unwrap()
}

/// One agent episode of `n` transitions.
fn walk(rng: &mut ChaCha8Rng, n: usize) -> (Vec<f32>, Vec<f32>) {
    random_walk(rng, n, OBS, ACT)
}

fn bench_filter(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let set = demos(0, 50, 1000);
    let (obs, act) = walk(&mut rng, 1000);
    let obs64: Vec<f64> = obs.iter().map(|&v| f64::from(v)).collect();
    let act64: Vec<f64> = act.iter().map(|&v| f64::from(v)).collect();
    let mut g = c.benchmark_group("filter");
    g.sample_size(10);
    for (name, mode) in [
        ("MeanDemoW5/MeanDemoW10", Mode::State),
        ("MeanBothW5/MeanBothW5", Mode::State),
        ("MinBoth/MinTrajW10", Mode::State),
        ("MinBoth/MinTrajW10", Mode::StateAction),
    ] {
        let strategy: Strategy = name.parse().unwrap();
        let prepared = Demonstrations::new(&set, mode, CostOptions::default()).unwrap();
        let mut filter = Filter::new(&prepared, strategy).unwrap();
        // A whole 1000-step episode; throughput = steps, so criterion reports time per step.
        g.throughput(Throughput::Elements(1000));
        g.bench_function(format!("episode_1000_steps/{mode}/{name}"), |b| {
            b.iter(|| {
                filter.reset();
                for t in 0..1000 {
                    black_box(
                        filter.push(&obs64[t * OBS..(t + 1) * OBS], &act64[t * ACT..(t + 1) * ACT]).unwrap(),
                    );
                }
            })
        });
    }
    g.finish();
}

fn bench_dynamics(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (obs, act) = walk(&mut rng, 2000);
    let obs: Vec<f64> = obs.iter().map(|&v| f64::from(v)).collect();
    let act: Vec<f64> = act.iter().map(|&v| f64::from(v)).collect();
    let cfg = DynamicsConfig { buffer_size: 100_000, ..DynamicsConfig::default() };
    let mut model = DynamicsModel::new(OBS, ACT, cfg, &mut rng).unwrap();
    model.set_parallelism(defender_nn::Parallelism::Sequential);
    for t in 0..1000 {
        model
            .observe(
                &obs[t * OBS..(t + 1) * OBS],
                &act[t * ACT..(t + 1) * ACT],
                &obs[(t + 1) * OBS..(t + 2) * OBS],
            )
            .unwrap();
    }
    let mut g = c.benchmark_group("dynamics");
    g.sample_size(10);
    let mut t = 1000;
    g.bench_function("observe_and_train_one_thread/hopper_dims", |b| {
        b.iter(|| {
            t = if t + 2 >= 2000 { 1000 } else { t + 1 };
            model
                .observe(
                    &obs[t * OBS..(t + 1) * OBS],
                    &act[t * ACT..(t + 1) * ACT],
                    &obs[(t + 1) * OBS..(t + 2) * OBS],
                )
                .unwrap();
        })
    });
    let mut out = vec![0.0; OBS];
    g.bench_function("predict/hopper_dims", |b| {
        b.iter(|| model.predict_into(&obs[..OBS], &act[..ACT], &mut out).unwrap())
    });
    g.finish();
}

fn bench_ablation(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let set = demos(2, 10, 200);
    let mut episodes = EpisodeSet::new(OBS, ACT, Meta::default()).unwrap();
    for i in 0..4 {
        let (obs, act) = walk(&mut rng, 200);
        episodes.push_episode(&obs, &act, &vec![1.0; 200], i % 2 == 0).unwrap();
    }
    let all: Vec<Strategy> = Strategy::all().collect();
    let prepared = Demonstrations::new(&set, Mode::State, CostOptions::default()).unwrap();
    let ablation = Ablation::new(&prepared, &all).unwrap();
    let mut g = c.benchmark_group("ablation");
    g.sample_size(10);
    g.bench_function("576_strategies/4_episodes_200_steps/10+10_demos_200_steps", |b| {
        b.iter(|| black_box(ablation.run(&episodes, &|_| {}).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench_filter, bench_dynamics, bench_ablation);
criterion_main!(benches);
