//! The filter's precision options (`[defender.filter]`) inside `DefenderEnv` on the line world:
//! the margin, the budget that moves it, own episodes joining the groups, and a checkpoint that
//! brings all of it back bit for bit.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

#[path = "common/line.rs"]
mod line;

use defender::{Budget, DefenderConfig, DefenderEnv, FilterOptions, OwnEpisodes};
use defender_rl::{Env, Outcome};
use line::{Line, config, line_demos};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn env(filter: FilterOptions) -> DefenderEnv<Line> {
    let cfg = DefenderConfig { filter, ..config("MinBothW5/MinBothW5") };
    DefenderEnv::new(Line::new(), &line_demos(), cfg, &mut ChaCha8Rng::seed_from_u64(0)).unwrap()
}

/// Runs right at `speed` until the episode ends; the outcome and the steps it took.
fn run_right(env: &mut DefenderEnv<Line>, speed: f64) -> (Outcome, usize) {
    env.reset(None).unwrap();
    for t in 1..=20 {
        let s = env.step(&[speed]).unwrap();
        if s.terminated || s.truncated {
            return (env.last_outcome().unwrap(), t);
        }
    }
    panic!("the line world always ends an episode that runs right");
}

#[test]
fn a_margin_lets_a_borderline_trajectory_run_and_a_large_one_lets_it_crash() {
    let (spec, t_spec) = run_right(&mut env(FilterOptions::default()), 1.0);
    assert_eq!(spec, Outcome::Filtered);
    let mut wide = env(FilterOptions { margin: 0.999, ..Default::default() });
    let (outcome, t) = run_right(&mut wide, 1.0);
    assert_eq!(outcome, Outcome::Crashed, "a margin near 1 filters almost nothing");
    assert!(t >= t_spec);
    assert_eq!(wide.adaptive_filter().margin(), 0.999);
}

#[test]
fn the_budget_moves_the_margin_after_each_episode() {
    let budget = Budget { share: 0.25, episodes: 10 };
    let mut e = env(FilterOptions { budget: Some(budget), ..Default::default() });
    assert_eq!(run_right(&mut e, 1.0).0, Outcome::Filtered);
    // (1 - 0.25) / 10 after a filtered episode ...
    assert_eq!(e.adaptive_filter().margin(), 0.075);
    // ... and -0.25 / 10 after one that was not (clamped at 0).
    e.reset(None).unwrap();
    let s = e.step(&[-3.5]).unwrap(); // jumps left out of bounds at once: a crash
    assert!(s.terminated && !s.info.filtered, "{:?}", e.last_decision());
    assert!((e.adaptive_filter().margin() - 0.05).abs() < 1e-15);
    let mut margins = Vec::new();
    for _ in 0..40 {
        run_right(&mut e, 1.0);
        margins.push(e.adaptive_filter().margin());
    }
    assert!(margins.windows(2).all(|w| w[1] >= w[0] || w[0] - w[1] <= 0.025 + 1e-12), "{margins:?}");
    assert!(*margins.last().unwrap() <= defender::MAX_ADAPTIVE_MARGIN);
}

#[test]
fn own_crashes_join_the_unsafe_group_up_to_keep() {
    let mut e = env(FilterOptions { own_episodes: Some(OwnEpisodes { keep: 2 }), ..Default::default() });
    assert_eq!(e.filter().demonstrations().unsafe_().len(), 3);
    for k in 0..3 {
        e.reset(None).unwrap();
        e.step(&[-3.5 - f64::from(k)]).unwrap();
        assert_eq!(e.last_outcome(), Some(Outcome::Crashed));
    }
    assert_eq!(e.adaptive_filter().own_counts(), (0, 2), "keep = 2: the oldest was replaced");
    assert_eq!(e.filter().demonstrations().unsafe_().len(), 5);
    assert_eq!(e.filter().demonstrations().safe().len(), 3);
    // A filtered episode joins no group.
    assert_eq!(run_right(&mut e, 1.0).0, Outcome::Filtered);
    assert_eq!(e.adaptive_filter().own_counts(), (0, 2));
    // The newest crash (x = -5.5) is now in the group: a trajectory like it is filtered.
    e.reset(None).unwrap();
    let d = e.step(&[-1.0]).map(|_| e.last_decision().unwrap()).unwrap();
    assert!(d.unsafe_cost.is_finite());
}

#[test]
fn own_episodes_cut_before_the_demonstrations_horizon_are_not_safe() {
    // The safe demonstrations last 10 steps: that is the task's horizon they were made with.
    let own = FilterOptions { own_episodes: Some(OwnEpisodes { keep: 5 }), ..Default::default() };
    for (limit, joined) in [(4, 0), (10, 3)] {
        let inner = defender_rl::TimeLimit::new(Line::new(), limit);
        let cfg = DefenderConfig { filter: own, ..config("MinBothW5/MinBothW5") };
        let mut e = DefenderEnv::new(inner, &line_demos(), cfg, &mut ChaCha8Rng::seed_from_u64(0)).unwrap();
        for _ in 0..3 {
            e.reset(None).unwrap();
            while !e.step(&[0.0]).map(|s| s.terminated || s.truncated).unwrap() {}
            assert_eq!(e.last_outcome(), Some(Outcome::Truncated), "time limit {limit}");
        }
        assert_eq!(e.adaptive_filter().own_counts(), (joined, 0), "time limit {limit}");
    }
}

/// A mixed run of episodes (left crashes, right runs, idling) under every variant at once.
fn actions(episode: usize) -> Vec<f64> {
    match episode % 3 {
        0 => vec![-1.2; 5],
        1 => vec![0.9; 8],
        _ => vec![0.05, -0.05, 0.05, -0.05, 0.02, 1.5, 1.5, 1.5],
    }
}

fn play(e: &mut DefenderEnv<Line>, episodes: std::ops::Range<usize>) -> Vec<(bool, u64, u64, u64)> {
    let mut trace = Vec::new();
    for k in episodes {
        e.reset(None).unwrap();
        for a in actions(k) {
            let s = e.step(&[a]).unwrap();
            let d = e.last_decision().unwrap();
            trace.push((d.filtered, d.safe_cost.to_bits(), d.unsafe_cost.to_bits(), s.obs[0].to_bits()));
            if s.terminated || s.truncated {
                break;
            }
        }
        trace.push((false, e.adaptive_filter().margin().to_bits(), 0, 0));
    }
    trace
}

#[test]
fn every_variant_resumes_from_a_checkpoint_bit_for_bit() {
    let all = FilterOptions {
        margin: 0.05,
        budget: Some(Budget { share: 0.3, episodes: 5 }),
        own_episodes: Some(OwnEpisodes { keep: 3 }),
        ..FilterOptions::default()
    };
    let mut straight = env(all);
    let whole = play(&mut straight, 0..12);
    assert_eq!(whole, play(&mut env(all), 0..12), "deterministic");

    let mut first = env(all);
    let head = play(&mut first, 0..6);
    let dir = tempfile::tempdir().unwrap();
    first.save_state(dir.path()).unwrap();
    let counts = first.adaptive_filter().own_counts();
    assert!(counts.0 + counts.1 > 0, "the groups grew before the checkpoint: {counts:?}");
    drop(first);
    let mut resumed = env(all);
    resumed.load_state(dir.path()).unwrap();
    assert_eq!(resumed.adaptive_filter().own_counts(), counts);
    let tail = play(&mut resumed, 6..12);
    assert_eq!([head, tail].concat(), whole);
}

#[test]
fn a_checkpoint_before_any_own_episode_resumes() {
    // A stop in the first episodes (Ctrl-C, or a short run whose every episode was filtered):
    // no own episode has joined yet, and the checkpoint must still load.
    let options =
        FilterOptions { margin: 0.02, own_episodes: Some(OwnEpisodes { keep: 3 }), ..Default::default() };
    let mut first = env(options);
    assert_eq!(run_right(&mut first, 1.0).0, Outcome::Filtered);
    assert_eq!(first.adaptive_filter().own_counts(), (0, 0));
    let dir = tempfile::tempdir().unwrap();
    first.save_state(dir.path()).unwrap();
    let mut resumed = env(options);
    resumed.load_state(dir.path()).unwrap();
    assert_eq!(resumed.adaptive_filter().own_counts(), (0, 0));
    assert_eq!(play(&mut resumed, 0..6), play(&mut first, 0..6));
}

#[test]
fn bad_settings_are_refused_naming_the_setting() {
    let bad = |filter: FilterOptions| {
        let cfg = DefenderConfig { filter, ..config("MinBothW5/MinBothW5") };
        DefenderEnv::new(Line::new(), &line_demos(), cfg, &mut ChaCha8Rng::seed_from_u64(0))
            .unwrap_err()
            .to_string()
    };
    assert!(bad(FilterOptions { margin: 1.0, ..Default::default() }).contains("margin = 1"));
    assert!(
        bad(FilterOptions { own_episodes: Some(OwnEpisodes { keep: 0 }), ..Default::default() })
            .contains("keep = 0")
    );
    let b = FilterOptions { budget: Some(Budget { share: 1.5, episodes: 5 }), ..Default::default() };
    assert!(bad(b).contains("share = 1.5"));
}
