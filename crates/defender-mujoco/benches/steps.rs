//! Environment steps per second per task, on one core: `MujocoEnv::step` with a fixed sinusoidal
//! action pattern (as an agent's would vary), resetting when an episode ends (the reset is part
//! of the measured loop, at its natural frequency).
//!
//! `cargo bench -p defender-mujoco --bench steps`

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use defender_mujoco::{Task, make};
use defender_rl::Env;

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("env_step");
    group.throughput(Throughput::Elements(1));
    for task in [Task::Hopper, Task::Walker2d, Task::InvertedDoublePendulum] {
        let mut env = make(task.id()).expect("task builds");
        env.reset(Some(0)).expect("reset");
        let act_dim = env.action_space().dim();
        // 64 precomputed actions in [-1, 1], cycled: no allocation in the loop but the observation.
        let actions: Vec<Vec<f64>> =
            (0..64).map(|t| (0..act_dim).map(|j| (0.3 * t as f64 + j as f64).sin()).collect()).collect();
        let mut t = 0usize;
        group.bench_function(task.id(), |b| {
            b.iter(|| {
                let step = env.step(&actions[t % actions.len()]).expect("step");
                t += 1;
                if step.done() {
                    env.reset(None).expect("reset");
                }
                black_box(step.obs)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, steps);
criterion_main!(benches);
