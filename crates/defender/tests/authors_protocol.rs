//! The authors' offline ablation and their choice of demonstrations for diversity against an
//! independent implementation: `tools/golden/authors_protocol_golden.py` (numpy and the PyPI `fastdtw`
//! package 0.3.4) wrote the inputs and the expected values in `tests/data/authors_protocol/`.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use defender::diversity::{diverse_order, select_diverse};
use defender::{CostOptions, EpisodeSet, Mode, Scoring, ablate_scored};

/// The golden sets' horizon (their safe demonstrations' length).
const HORIZON: usize = 25;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/authors_protocol").join(name)
}

/// `strategy -> (mean_ratio, safe_rate, score)` of a golden CSV.
fn golden(case: &str) -> HashMap<String, (f64, f64, f64)> {
    let text = std::fs::read_to_string(data(&format!("scores-{case}.csv"))).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].to_string(), (f[2].parse().unwrap(), f[3].parse().unwrap(), f[4].parse().unwrap()))
        })
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
}

fn check(case: &str, demos: &EpisodeSet, mode: Mode) {
    let episodes = EpisodeSet::load(data("episodes.npz")).unwrap();
    let want = golden(case);
    let rows = ablate_scored(
        demos,
        &episodes,
        None,
        mode,
        CostOptions::authors(),
        Scoring::Authors { horizon: HORIZON },
        &|_| {},
    )
    .unwrap();
    assert_eq!(rows.len(), 576);
    let mut nonzero = 0;
    for r in &rows {
        let (ratio, safe, score) = want[&r.strategy.to_string()];
        assert!(
            close(r.mean_ratio, ratio) && close(r.safe_rate, safe) && close(r.score, score),
            "{case} {}: ({}, {}, {}) against the reference's ({ratio}, {safe}, {score})",
            r.strategy,
            r.mean_ratio,
            r.safe_rate,
            r.score
        );
        nonzero += usize::from(score > 0.0);
    }
    assert!(nonzero > 100, "{case}: only {nonzero} strategies score above 0");
    // Ranked by score, highest first.
    assert!(rows.windows(2).all(|w| w[0].score >= w[1].score));
}

#[test]
fn the_authors_ablation_matches_the_reference_in_both_modes() {
    let demos = EpisodeSet::load(data("demos.npz")).unwrap();
    check("state", &demos, Mode::State);
    check("state-action", &demos, Mode::StateAction);
}

#[test]
fn the_authors_ablation_on_demonstrations_chosen_for_diversity_matches_the_reference() {
    let demos = EpisodeSet::load(data("demos.npz")).unwrap();
    check("state-diverse3", &select_diverse(&demos, 3, Mode::State).unwrap(), Mode::State);
}

#[test]
fn ties_execute_under_the_authors_cost() {
    // Each unsafe demonstration ends with the last 10 elements of a safe one: with the same
    // aggregation on both sides, windows of the demonstrations' last 5 or 10 steps tie at every
    // step. Ties execute: never filtered, p = 1, no crash avoided, score 0.
    let want = golden("state");
    for strategy in ["MinDemoW5/MinDemoW5", "MeanBothW10/MeanBothW10", "MaxDemoW10/MaxDemoW10"] {
        assert_eq!(want[strategy], (1.0, 0.0, 0.0), "{strategy}");
    }
}

#[test]
fn the_diversity_order_matches_the_reference() {
    let demos = EpisodeSet::load(data("demos.npz")).unwrap();
    let text = std::fs::read_to_string(data("diverse.txt")).unwrap();
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let mode: Mode = f[0].parse().unwrap();
        let want: Vec<usize> = f[2..].iter().map(|v| v.parse().unwrap()).collect();
        let (safe, unsafe_) = diverse_order(&demos, want.len(), mode).unwrap();
        let got = if f[1] == "safe" { safe } else { unsafe_ };
        assert_eq!(got, want, "{line}");
    }
}
