//! Wall time of the offline ablation at Hopper scale on synthetic data: 50 + 50 demonstrations of
//! 1000 transitions (11-D smooth random walks), recorded episodes of LEN steps, all 576 strategies
//! or only those without the `Equal` window.
//!
//! `cargo run --release -p defender --example ablation_scale [EPISODES] [LEN]`

use std::time::Instant;

use defender::synthetic::{WalkSet, random_walk};
use defender::{Ablation, CostOptions, Demonstrations, EpisodeSet, Meta, Mode, Strategy, Window};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let episodes: usize = args.get(1).map_or(Ok(2), |s| s.parse())?;
    let len: usize = args.get(2).map_or(Ok(1000), |s| s.parse())?;
    let demos = WalkSet::HOPPER.build(0, Meta::default())?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut recorded = EpisodeSet::new(11, 3, Meta::default())?;
    for i in 0..episodes {
        let (o, a) = random_walk(&mut rng, len, 11, 3);
        recorded.push_episode(&o, &a, &vec![1.0; len], i % 2 == 0)?;
    }
    let prepared = Demonstrations::new(&demos, Mode::State, CostOptions::default())?;
    let all: Vec<Strategy> = Strategy::all().collect();
    let no_equal: Vec<Strategy> = all
        .iter()
        .copied()
        .filter(|s| s.safe.window != Window::Equal && s.unsafe_.window != Window::Equal)
        .collect();
    for (name, list) in [("without Equal", &no_equal), ("all 576", &all)] {
        let start = Instant::now();
        let rows = Ablation::new(&prepared, list)?.run(&recorded, &|_| {})?;
        println!(
            "{name}: {} strategies, {episodes} episodes of {len} steps: {:.2} s (best: {} score {:.3})",
            rows.len(),
            start.elapsed().as_secs_f64(),
            rows[0].strategy,
            rows[0].score
        );
    }
    Ok(())
}
