//! Time per filter step along a 1000-step episode, in buckets of 100 steps (median over episodes),
//! on Hopper-shaped synthetic data (50 + 50 smooth random walks of 1000 transitions, 11-D).
//!
//! `cargo run --release -p defender --example filter_steps [STRATEGY] [MODE] [EPISODES]`

use std::time::Instant;

use defender::synthetic::{WalkSet, random_walk};
use defender::{CostOptions, Demonstrations, Filter, Meta, Mode, Strategy};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let strategy: Strategy = args.get(1).map_or("MeanDemoW5/MeanDemoW10", String::as_str).parse()?;
    let mode: Mode = args.get(2).map_or("state", String::as_str).parse()?;
    let episodes: usize = args.get(3).map_or(Ok(5), |s| s.parse())?;
    let shape = WalkSet::HOPPER;
    let (obs_dim, act_dim, len) = (shape.obs_dim, shape.act_dim, shape.len);
    let set = shape.build(0, Meta::default())?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let demos = Demonstrations::new(&set, mode, CostOptions::default())?;
    let mut filter = Filter::new(&demos, strategy)?;
    let (obs, act) = random_walk(&mut rng, len, obs_dim, act_dim);
    let obs: Vec<f64> = obs.iter().map(|&v| f64::from(v)).collect();
    let act: Vec<f64> = act.iter().map(|&v| f64::from(v)).collect();
    let mut per_step = vec![Vec::new(); len];
    for _ in 0..episodes {
        filter.reset();
        for t in 0..len {
            let start = Instant::now();
            std::hint::black_box(
                filter.push(&obs[t * obs_dim..(t + 1) * obs_dim], &act[t * act_dim..(t + 1) * act_dim])?,
            );
            per_step[t].push(start.elapsed().as_secs_f64() * 1e6);
        }
    }
    println!("{strategy} ({mode}), 50+50 demonstrations of {len} transitions, {episodes} episodes");
    println!("steps       median us/step   max of bucket medians");
    for b in (0..len).step_by(100) {
        let mut meds: Vec<f64> = per_step[b..b + 100]
            .iter()
            .map(|v| {
                let mut v = v.clone();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            })
            .collect();
        meds.sort_by(f64::total_cmp);
        println!("{:4}-{:4}   {:10.2}       {:10.2}", b + 1, b + 100, meds[50], meds[99]);
    }
    Ok(())
}
