//! The per-step paths allocate nothing once warm: the filter's push (after a first episode of
//! the same length) and the dynamics model's observe-and-train step. Counted by a global
//! allocator, per thread (so other tests running in parallel do not interfere).

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

use defender::{
    CostOptions, Demonstrations, DynamicsConfig, DynamicsModel, EpisodeSet, Filter, Meta, Mode, Strategy,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[global_allocator]
static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;

fn random_set(rng: &mut ChaCha8Rng) -> EpisodeSet {
    let mut set = EpisodeSet::new(4, 2, Meta::default()).unwrap();
    for i in 0..6 {
        let n = 30 + 5 * i;
        let obs: Vec<f32> = (0..(n + 1) * 4).map(|_| rng.random_range(-1.0..1.0)).collect();
        let act: Vec<f32> = (0..n * 2).map(|_| rng.random_range(-1.0..1.0)).collect();
        set.push_episode(&obs, &act, &vec![0.0; n], i % 2 == 0).unwrap();
    }
    set
}

#[test]
fn filter_push_allocates_nothing_once_warm() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let set = random_set(&mut rng);
    let obs: Vec<f64> = (0..100 * 4).map(|_| rng.random_range(-1.0..1.0)).collect();
    let act: Vec<f64> = (0..100 * 2).map(|_| rng.random_range(-1.0..1.0)).collect();
    for mode in Mode::ALL {
        let demos = Demonstrations::new(&set, mode, CostOptions::default()).unwrap();
        for name in
            ["MeanDemoW5/MeanDemoW10", "MeanBothW5/MeanBothW5", "MinBoth/MinTrajW10", "MaxBothW10/MinDemoW5"]
        {
            let mut filter = Filter::new(&demos, name.parse::<Strategy>().unwrap()).unwrap();
            let episode = |f: &mut Filter| {
                f.reset();
                for t in 0..100 {
                    f.push(&obs[t * 4..(t + 1) * 4], &act[t * 2..(t + 1) * 2]).unwrap();
                }
            };
            let cold = alloc_counter::allocations();
            episode(&mut filter);
            assert!(alloc_counter::allocations() > cold, "the counter sees the first episode's growth");
            let before = alloc_counter::allocations();
            episode(&mut filter);
            assert_eq!(
                alloc_counter::allocations() - before,
                0,
                "{name} ({mode}) allocated during a warm episode"
            );
        }
    }
}

#[test]
fn dynamics_observe_allocates_nothing_once_warm() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let cfg = DynamicsConfig {
        buffer_size: 1000,
        batch_size: 32,
        hidden: vec![64, 64],
        ..DynamicsConfig::spec_schedule()
    };
    let mut model = DynamicsModel::new(4, 2, cfg, &mut rng).unwrap();
    model.set_parallelism(defender_nn::Parallelism::Sequential);
    let mut out = vec![0.0; 4];
    let mut step = |model: &mut DynamicsModel, rng: &mut ChaCha8Rng| {
        let s: [f64; 4] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let a: [f64; 2] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let n: [f64; 4] = std::array::from_fn(|k| s[k] + 0.1 * a[k % 2]);
        model.observe(&s, &a, &n).unwrap();
        model.predict_into(&s, &a, &mut out).unwrap();
    };
    for _ in 0..5 {
        step(&mut model, &mut rng);
    }
    let before = alloc_counter::allocations();
    for _ in 0..50 {
        step(&mut model, &mut rng);
    }
    assert_eq!(alloc_counter::allocations() - before, 0, "observe/predict allocated once warm");
    assert_eq!(model.gradient_steps(), 55);
}
