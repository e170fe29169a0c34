//! The work-sharing ablation and the incremental online filter against the direct implementation
//! (`tests/common/direct.rs`: every window of every step recomputed from scratch with the textbook DTW),
//! on small random sets, in both modes, for all 576 strategies.

#![allow(clippy::unwrap_used)] // test and bench helpers fail loudly on purpose

use std::sync::atomic::{AtomicUsize, Ordering};

#[path = "common/direct.rs"]
mod direct;

use defender::{Ablation, CostOptions, Demonstrations, EpisodeSet, Filter, Meta, Mode, Strategy};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Episodes whose element differences are exact in f32 arithmetic: obs = 3k, act = 4k with small
/// integers k, so every local cost (|3d| in state mode, 5|d| in state-action mode) and every sum
/// is an exact small integer. The kernels and the direct f64 recursion then agree bit for bit,
/// and exact ties (which must filter) occur.
fn integer_set(
    rng: &mut ChaCha8Rng,
    episodes: usize,
    len: std::ops::RangeInclusive<usize>,
    crash_p: f64,
) -> EpisodeSet {
    let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
    for _ in 0..episodes {
        let n = rng.random_range(len.clone());
        let mut k: i32 = rng.random_range(-2..=2);
        let mut obs = Vec::new();
        let mut act = Vec::new();
        for i in 0..=n {
            obs.push(3.0 * k as f32);
            if i < n {
                act.push(4.0 * k as f32);
            }
            k += rng.random_range(-1..=2);
        }
        let rew: Vec<f32> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        set.push_episode(&obs, &act, &rew, rng.random_bool(crash_p)).unwrap();
    }
    set
}

/// Smooth random walks in 3 + 2 dimensions (f32 arithmetic differs from f64 by rounding).
fn float_set(
    rng: &mut ChaCha8Rng,
    episodes: usize,
    len: std::ops::RangeInclusive<usize>,
    crash_p: f64,
) -> EpisodeSet {
    let mut set = EpisodeSet::new(3, 2, Meta::default()).unwrap();
    for _ in 0..episodes {
        let n = rng.random_range(len.clone());
        let mut s = [rng.random_range(-1.0f32..1.0), rng.random_range(-1.0f32..1.0), 0.0];
        let mut obs = Vec::new();
        let mut act = Vec::new();
        for i in 0..=n {
            obs.extend_from_slice(&s);
            if i < n {
                let a = [rng.random_range(-1.0f32..1.0), rng.random_range(-1.0f32..1.0)];
                act.extend_from_slice(&a);
                s = [s[0] + 0.3 * a[0], s[1] + 0.3 * a[1], s[2] + 0.1];
            }
        }
        let rew: Vec<f32> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        set.push_episode(&obs, &act, &rew, rng.random_bool(crash_p)).unwrap();
    }
    set
}

fn demos_with_both_groups(make: impl Fn(&mut ChaCha8Rng) -> EpisodeSet, rng: &mut ChaCha8Rng) -> EpisodeSet {
    loop {
        let set = make(rng);
        if set.require_both_groups().is_ok() {
            return set;
        }
    }
}

#[test]
fn ablation_scores_equal_the_direct_implementation_exactly_on_exact_data() {
    let all: Vec<Strategy> = Strategy::all().collect();
    for (seed, mode) in [(1, Mode::State), (2, Mode::StateAction), (3, Mode::State)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let demos = demos_with_both_groups(|r| integer_set(r, 6, 2..=14, 0.5), &mut rng);
        let episodes = integer_set(&mut rng, 10, 1..=18, 0.5);
        let prepared = Demonstrations::new(&demos, mode, CostOptions::default()).unwrap();
        let calls = AtomicUsize::new(0);
        let rows = Ablation::new(&prepared, &all)
            .unwrap()
            .run(&episodes, &|p| {
                calls.fetch_add(1, Ordering::Relaxed);
                assert_eq!(p.total, 10);
            })
            .unwrap();
        assert_eq!(calls.load(Ordering::Relaxed), 10, "one progress call per episode");
        let expected = direct::ablation(&demos, &episodes, &all, mode);
        assert_eq!(rows.len(), 576);
        for (a, b) in rows.iter().zip(&expected) {
            assert_eq!(a, b, "seed {seed}, mode {mode}");
        }
        // The scores are not all alike (the cross-check would be weak otherwise).
        let distinct: std::collections::BTreeSet<u64> = rows.iter().map(|r| r.score.to_bits()).collect();
        assert!(distinct.len() > 10, "seed {seed}: only {} distinct scores", distinct.len());
    }
}

#[test]
fn ablation_replays_match_the_direct_implementation_on_float_data() {
    let all: Vec<Strategy> = Strategy::all().collect();
    for (seed, mode) in [(10, Mode::State), (11, Mode::StateAction)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let demos = demos_with_both_groups(|r| float_set(r, 6, 3..=16, 0.5), &mut rng);
        let episodes = float_set(&mut rng, 6, 1..=20, 0.5);
        let prepared = Demonstrations::new(&demos, mode, CostOptions::default()).unwrap();
        let ablation = Ablation::new(&prepared, &all).unwrap();
        let replays = ablation.replay_all(&episodes, &|_| {}).unwrap();
        let (mut cases, mut near_ties) = (0, 0);
        for (si, &s) in ablation.strategies().iter().enumerate() {
            for e in episodes.episodes() {
                let ds = direct::decisions(s, mode, &demos, e);
                let k_direct = ds.iter().position(|d| d.filtered);
                let k = replays[e.index].first_filtered[si];
                cases += 1;
                if k != k_direct {
                    // Only a decision within f32 rounding of a tie may differ.
                    let t = k.unwrap_or(usize::MAX).min(k_direct.unwrap_or(usize::MAX));
                    let d = ds[t];
                    let margin = (d.safe_cost - d.unsafe_cost).abs() / d.safe_cost.abs().max(1e-9);
                    assert!(
                        margin < 1e-5,
                        "{s} episode {}: ablation k={k:?}, direct k={k_direct:?}, {d:?}",
                        e.index
                    );
                    near_ties += 1;
                }
            }
        }
        assert!(near_ties * 100 <= cases, "{near_ties} near ties of {cases}");
    }
}

#[test]
fn the_online_filter_decides_as_the_direct_implementation() {
    let strategies: Vec<Strategy> = [
        "MeanDemoW5/MeanDemoW10",
        "MeanBothW5/MeanBothW5",
        "MinBoth/MinTrajW10",
        "MaxEqual/MinEqual",
        "MinEqual/MeanBothW10",
        "MeanTrajW5/MaxDemoW5",
    ]
    .iter()
    .map(|s| s.parse().unwrap())
    .collect();
    for mode in Mode::ALL {
        let mut rng = ChaCha8Rng::seed_from_u64(20);
        let demos = demos_with_both_groups(|r| float_set(r, 8, 3..=25, 0.5), &mut rng);
        let episodes = float_set(&mut rng, 5, 10..=30, 0.3);
        let prepared = Demonstrations::new(&demos, mode, CostOptions::default()).unwrap();
        for &s in &strategies {
            let mut filter = Filter::new(&prepared, s).unwrap();
            for e in episodes.episodes() {
                filter.reset();
                // Push every step, filtered or not, to exercise long trajectories.
                for t in 0..e.len() {
                    let d = filter.push_f32(e.observation(t), e.action(t)).unwrap();
                    let x = &e.sequence(mode)[..(t + 1) * prepared.element_dim()];
                    let safe: Vec<Vec<f32>> = demos.safe().map(|d| d.sequence(mode)).collect();
                    let unsafe_: Vec<Vec<f32>> = demos.unsafe_().map(|d| d.sequence(mode)).collect();
                    let dim = prepared.element_dim();
                    let sv = direct::group_value(s.safe, x, &safe, dim);
                    let uv = direct::group_value(s.unsafe_, x, &unsafe_, dim);
                    assert!(
                        (d.safe_cost - sv).abs() <= 1e-5 * sv.abs().max(1.0),
                        "{s} t={t}: {} vs {sv}",
                        d.safe_cost
                    );
                    assert!(
                        (d.unsafe_cost - uv).abs() <= 1e-5 * uv.abs().max(1.0),
                        "{s} t={t}: {} vs {uv}",
                        d.unsafe_cost
                    );
                    if (sv - uv).abs() > 1e-4 * sv.abs().max(1.0) {
                        assert_eq!(d.filtered, sv >= uv, "{s} t={t}");
                    }
                }
            }
        }
    }
}

#[test]
fn a_strategy_subset_scores_as_in_the_full_run() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let demos = demos_with_both_groups(|r| integer_set(r, 6, 2..=10, 0.5), &mut rng);
    let episodes = integer_set(&mut rng, 8, 1..=12, 0.5);
    let subset: Vec<Strategy> =
        Strategy::parse_list("MinBoth/MinTrajW10,MeanDemoW5/MeanDemoW10,MeanBothW5/MeanBothW5").unwrap();
    let rows =
        defender::ablate(&demos, &episodes, Some(&subset), Mode::State, CostOptions::default(), &|_| {})
            .unwrap();
    let full =
        defender::ablate(&demos, &episodes, None, Mode::State, CostOptions::default(), &|_| {}).unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        let f = full.iter().find(|f| f.strategy == r.strategy).unwrap();
        assert_eq!((r.mean_ratio, r.safe_rate, r.score), (f.mean_ratio, f.safe_rate, f.score));
    }
}
