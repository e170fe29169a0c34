//! Choosing the strategy automatically (`defender::selection`): leave-one-out against filters
//! built without the held-out demonstration, determinism, the late-divergence task, and bad input.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

use defender::selection::{AUTO_COSTS, Selection, SelectionConfig, select};
use defender::synthetic::LateDivergence;
use defender::{
    CostOptions, DefenderError, Demonstrations, EpisodeSet, Filter, Meta, Mode, Scaling, Strategy,
};

fn quiet() -> impl Fn(defender::Progress) + Sync {
    |_| {}
}

/// The set without episode `skip`.
fn without(set: &EpisodeSet, skip: usize) -> EpisodeSet {
    let mut out = EpisodeSet::new(set.obs_dim(), set.act_dim(), Meta::default()).unwrap();
    for e in set.episodes().filter(|e| e.index != skip) {
        out.push_episode(e.obs, e.act, e.rew, e.crashed).unwrap();
    }
    out
}

/// The first filtered step of `strategy` on episode `i` of `set`, with a filter built from the
/// other episodes: the definition of leave-one-out, computed the slow way.
fn held_out_first_filtered(set: &EpisodeSet, i: usize, strategy: Strategy, mode: Mode) -> Option<usize> {
    let demos = Demonstrations::new(&without(set, i), mode, CostOptions::default()).unwrap();
    let mut filter = Filter::new(&demos, strategy).unwrap();
    let e = set.episode(i);
    (0..e.len()).find(|&t| filter.push_f32(e.observation(t), e.action(t)).unwrap().filtered)
}

#[test]
fn leave_one_out_equals_filters_built_without_the_held_out_demonstration() {
    let shape = LateDivergence { per_group: 3, len: 14, diverge_at: 8, ..LateDivergence::SMALL };
    let set = shape.build(11, Meta::default()).unwrap();
    for mode in Mode::ALL {
        // Every 7th strategy: all windows and aggregations occur on both sides.
        let strategies: Vec<Strategy> = Strategy::all().step_by(7).collect();
        let config = SelectionConfig { mode, strategies: Some(strategies.clone()), ..Default::default() };
        let selection = select(&set, None, &config, &quiet()).unwrap();
        assert_eq!(selection.rows.len(), strategies.len());
        for &s in &strategies {
            let (mut alarms, mut prevented, mut safe_allowed) = (0usize, 0usize, 0.0f64);
            for i in 0..set.len() {
                let e = set.episode(i);
                let k = held_out_first_filtered(&set, i, s, mode);
                if e.crashed {
                    prevented += usize::from(k.is_some());
                } else {
                    alarms += usize::from(k.is_some());
                    safe_allowed += k.map_or(1.0, |k| (k + 1) as f64 / e.len() as f64);
                }
            }
            let row = selection.get(s, Scaling::None).unwrap();
            assert_eq!(row.false_alarm_rate, alarms as f64 / 3.0, "{s} {mode}");
            assert_eq!(row.crash_prevention_rate, prevented as f64 / 3.0, "{s} {mode}");
            assert_eq!(row.safe_allowed, safe_allowed / 3.0, "{s} {mode}");
        }
    }
}

#[test]
fn the_selection_is_deterministic() {
    let set = LateDivergence::SMALL.build(3, Meta::default()).unwrap();
    let config = SelectionConfig { equal: false, ..Default::default() };
    let a = select(&set, None, &config, &quiet()).unwrap();
    let b = select(&set, None, &config, &quiet()).unwrap();
    // One thread: the same ranking whatever the parallel schedule.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let c = pool.install(|| select(&set, None, &config, &quiet()).unwrap());
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_eq!(a.rows.len(), 441);
    let ranks: Vec<usize> = a.rows.iter().map(|r| r.rank).collect();
    assert_eq!(ranks, (1..=441).collect::<Vec<_>>());
    // Same CSV bytes.
    let dir = tempfile::tempdir().unwrap();
    a.write_csv(dir.path().join("a.csv")).unwrap();
    c.write_csv(dir.path().join("c.csv")).unwrap();
    let text = std::fs::read_to_string(dir.path().join("a.csv")).unwrap();
    assert_eq!(text, std::fs::read_to_string(dir.path().join("c.csv")).unwrap());
    assert!(text.starts_with(defender::selection::SELECTION_CSV_HEADER));
    assert_eq!(text.lines().count(), 442);
}

fn check_choice(selection: &Selection, set: &EpisodeSet, mode: Mode) {
    let best = selection.best().expect("a strategy is eligible");
    assert_eq!(best.rank, 1);
    assert_eq!(best.false_alarm_rate, 0.0, "{best:?}");
    assert_eq!(best.crash_prevention_rate, 1.0, "{best:?}");
    // Checked the slow way: every held-out unsafe demonstration is filtered, after the
    // divergence, and no safe one is.
    for i in 0..set.len() {
        let k = held_out_first_filtered(set, i, best.strategy, mode);
        if set.episode(i).crashed {
            let k = k.unwrap_or_else(|| panic!("{} misses unsafe demonstration {i}", best.strategy));
            assert!(k > LateDivergence::SMALL.diverge_at / 2, "{} filters {i} at {k}", best.strategy);
        } else {
            assert_eq!(k, None, "{} filters safe demonstration {i}", best.strategy);
        }
    }
}

#[test]
fn late_divergence_chooses_a_strategy_that_filters_the_unsafe_and_not_the_safe() {
    let set = LateDivergence::SMALL.build(5, Meta::default()).unwrap();
    for mode in Mode::ALL {
        let config = SelectionConfig { mode, equal: false, ..Default::default() };
        let selection = select(&set, None, &config, &quiet()).unwrap();
        check_choice(&selection, &set, mode);
        // Not every strategy is this good: the choice matters.
        let bad = selection.rows.iter().filter(|r| r.demo_score < 0.5).count();
        assert!(bad > 100, "{bad} strategies score below 0.5");
    }
}

#[test]
fn never_chooses_a_strategy_that_filters_every_held_out_safe_demonstration() {
    // Unsafe demonstrations are copies of safe ones: a held-out safe demonstration's copy stays
    // in the unsafe group, so `Min` over the unsafe group is 0 and many strategies raise an alarm
    // on every safe demonstration.
    let base = LateDivergence::SMALL.build(7, Meta::default()).unwrap();
    let mut set = EpisodeSet::new(base.obs_dim(), base.act_dim(), Meta::default()).unwrap();
    for e in base.safe() {
        set.push_episode(e.obs, e.act, e.rew, false).unwrap();
        set.push_episode(e.obs, e.act, e.rew, true).unwrap();
    }
    // Without a false-alarm budget, only the strategies that filter every held-out safe
    // demonstration are left out.
    let config = SelectionConfig { equal: false, max_false_alarm: 1.0, ..Default::default() };
    let selection = select(&set, None, &config, &quiet()).unwrap();
    let all_alarms: Vec<_> = selection.rows.iter().filter(|r| r.false_alarm_rate == 1.0).collect();
    assert!(!all_alarms.is_empty());
    let first_ineligible = all_alarms.iter().map(|r| r.rank).min().unwrap();
    for r in &selection.rows {
        assert_eq!(r.eligible, r.false_alarm_rate < 1.0);
        assert!(r.eligible == (r.rank < first_ineligible), "{r:?}");
    }
    if let Some(best) = selection.best() {
        assert!(best.false_alarm_rate < 1.0);
    }
    // The default budget (10%) leaves out more.
    let budget =
        select(&set, None, &SelectionConfig { equal: false, ..Default::default() }, &quiet()).unwrap();
    for r in &budget.rows {
        assert_eq!(r.eligible, r.false_alarm_rate <= 0.1, "{r:?}");
    }
    if let Some(best) = budget.best() {
        assert!(best.false_alarm_rate <= 0.1);
    }
    // Restricted to strategies that all alarm on every safe demonstration: nothing is chosen.
    let only_bad: Vec<Strategy> = all_alarms.iter().map(|r| r.strategy).collect();
    let config = SelectionConfig { strategies: Some(only_bad), max_false_alarm: 1.0, ..Default::default() };
    let selection = select(&set, None, &config, &quiet()).unwrap();
    assert!(selection.best().is_none());
}

#[test]
fn recorded_episodes_multiply_in_the_ablation_score() {
    let set = LateDivergence::SMALL.build(5, Meta::default()).unwrap();
    let episodes =
        LateDivergence { per_group: 3, ..LateDivergence::SMALL }.build(6, Meta::default()).unwrap();
    let config = SelectionConfig { equal: false, ..Default::default() };
    let demo_only = select(&set, None, &config, &quiet()).unwrap();
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let both = select(&set, Some(&episodes), &config, &|p| {
        assert_eq!(p.total, 16 + 6);
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(calls.into_inner(), 22);
    assert_eq!(both.episodes, 6);
    let ablation = defender::ablate(
        &set,
        &episodes,
        Some(&config.candidates()),
        Mode::State,
        CostOptions::default(),
        &quiet(),
    )
    .unwrap();
    for a in &ablation {
        let row = both.get(a.strategy, Scaling::None).unwrap();
        assert_eq!(row.ablation_score, Some(a.score));
        assert_eq!(row.demo_score, demo_only.get(a.strategy, Scaling::None).unwrap().demo_score);
        assert_eq!(row.score, row.demo_score * a.score);
    }
}

/// The late-divergence task with a wide, uninformative third feature (as a joint velocity is on
/// Hopper-v5 and Walker2d-v5: docs/decisions.md, "z-scored DTW"): its noise, 1000 times the scale
/// of the others, drowns the late drift of the first feature in the raw Euclidean cost.
fn drowned_divergence(seed: u64) -> EpisodeSet {
    let base = LateDivergence::SMALL.build(seed, Meta::default()).unwrap();
    let mut set = EpisodeSet::new(base.obs_dim(), base.act_dim(), Meta::default()).unwrap();
    for e in base.episodes() {
        let mut obs = e.obs.to_vec();
        obs.iter_mut().skip(2).step_by(3).for_each(|v| *v *= 1000.0);
        set.push_episode(&obs, e.act, e.rew, e.crashed).unwrap();
    }
    set
}

#[test]
fn auto_compares_plain_and_z_scored_dtw_and_keeps_the_better() {
    let set = drowned_divergence(5);
    let auto = SelectionConfig::for_run(Mode::State, None, None);
    assert_eq!(auto.costs, AUTO_COSTS);
    assert!(!auto.equal);
    let both = select(&set, None, &auto, &quiet()).unwrap();
    assert_eq!(both.rows.len(), 2 * 441);
    // Each cost's rows are exactly that cost's selection alone.
    for cost in AUTO_COSTS {
        let alone =
            select(&set, None, &SelectionConfig::for_run(Mode::State, None, Some(cost)), &quiet()).unwrap();
        assert_eq!(alone.rows.len(), 441);
        assert!(alone.rows.iter().all(|r| r.scaling == cost.scaling));
        for r in &alone.rows {
            let mut same = both.get(r.strategy, cost.scaling).unwrap().clone();
            same.rank = r.rank;
            assert_eq!(&same, r);
        }
        assert_eq!(alone.best(), alone.best_under(cost.scaling));
        assert_eq!(both.best_under(cost.scaling).map(|r| r.strategy), alone.best().map(|r| r.strategy));
    }
    // The noise hides the drift from plain DTW; z-scored, it is caught without false alarms.
    let plain = both.best_under(Scaling::None).map_or(0.0, |r| r.score);
    let best = both.best().unwrap();
    assert_eq!(best.scaling, Scaling::Zscore, "{best:?}");
    assert_eq!((best.false_alarm_rate, best.crash_prevention_rate), (0.0, 1.0), "{best:?}");
    assert!(plain < 0.75, "plain DTW's best scores {plain}");
    // The CSV names each row's scaling.
    let dir = tempfile::tempdir().unwrap();
    both.write_csv(dir.path().join("s.csv")).unwrap();
    let text = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    assert!(text.lines().next().unwrap().contains(",mode,scaling,"));
    assert!(text.lines().nth(1).unwrap().contains(",state,zscore,"), "{text:.300}");
}

#[test]
fn bad_input_is_a_clear_error() {
    let set = LateDivergence { per_group: 3, len: 10, diverge_at: 5, ..LateDivergence::SMALL }
        .build(1, Meta::default())
        .unwrap();
    let config = SelectionConfig { equal: false, ..Default::default() };
    // A group missing.
    let mut only_safe = EpisodeSet::new(set.obs_dim(), set.act_dim(), Meta::default()).unwrap();
    for e in set.safe() {
        only_safe.push_episode(e.obs, e.act, e.rew, false).unwrap();
    }
    let err = select(&only_safe, None, &config, &quiet()).unwrap_err();
    assert!(matches!(err, DefenderError::MissingGroup { group: "unsafe", .. }), "{err}");
    // One demonstration in a group.
    let err = select(&set, None, &SelectionConfig { num_demos: Some(1), ..config.clone() }, &quiet())
        .unwrap_err()
        .to_string();
    assert!(err.contains("at least 2 per group") && err.contains("the safe group has 1"), "{err}");
    let mut one_unsafe = without(&set, 1);
    one_unsafe = without(&one_unsafe, 2);
    let err = select(&one_unsafe, None, &config, &quiet()).unwrap_err().to_string();
    assert!(err.contains("the unsafe group has 1"), "{err}");
    // More demonstrations asked for than there are.
    let err =
        select(&set, None, &SelectionConfig { num_demos: Some(4), ..config.clone() }, &quiet()).unwrap_err();
    assert!(matches!(err, DefenderError::NotEnoughDemos { asked: 4, .. }), "{err}");
    // NaN never gets into a set.
    let mut nan = EpisodeSet::new(set.obs_dim(), set.act_dim(), Meta::default()).unwrap();
    let e = set.episode(0);
    let mut obs = e.obs.to_vec();
    obs[4] = f32::NAN;
    let err = nan.push_episode(&obs, e.act, e.rew, false).unwrap_err().to_string();
    assert!(err.contains("'obs'") && err.contains("NaN"), "{err}");
    // No strategy, a zero lead time, episodes of another task.
    let err = select(&set, None, &SelectionConfig { strategies: Some(vec![]), ..config.clone() }, &quiet())
        .unwrap_err()
        .to_string();
    assert!(err.contains("no strategy"), "{err}");
    let err = select(&set, None, &SelectionConfig { min_lead: 0, ..config.clone() }, &quiet())
        .unwrap_err()
        .to_string();
    assert!(err.contains("min_lead"), "{err}");
    for (costs, expected) in
        [(vec![], "no alignment cost"), (vec![CostOptions::default(); 2], "listed twice")]
    {
        let err = select(&set, None, &SelectionConfig { costs, ..config.clone() }, &quiet())
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "{err}");
    }
    for bad in [f64::NAN, -0.1, 1.5] {
        let err = select(&set, None, &SelectionConfig { max_false_alarm: bad, ..config.clone() }, &quiet())
            .unwrap_err()
            .to_string();
        assert!(err.contains("max_false_alarm must be a rate in [0, 1]"), "{err}");
    }
    let other = LateDivergence { obs_dim: 4, ..LateDivergence::SMALL }.build(1, Meta::default()).unwrap();
    let err = select(&set, Some(&other), &config, &quiet()).unwrap_err().to_string();
    assert!(err.contains("'obs'") && err.contains("4 columns"), "{err}");
}
