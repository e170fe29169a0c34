//! `defender demos risk-horizon` through the binary. On a constructed demonstration set with an
//! untrained critic (one pretraining step: every sigmoid output lies far inside (0.01, 0.99))
//! the answer is known: at eps_risk 0.01 every step is flagged, so each held-out unsafe
//! demonstration's lead is its length minus one, and at 0.99 none is. On the shipped set with a
//! short pretraining, the measure's own consistency: a higher eps_risk flags less, seconds are
//! steps times the task's dt, the same seed repeats. Bad input is refused with a message.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};

mod common;

use common::{ok, refused, s};

/// dt = 0.01 s x 5 frames; 9 observations, 1 action in [-1, 1].
const ENV_ID: &str = "InvertedDoublePendulum-v5";
const DT: f64 = 0.05;

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos").join(format!("{ENV_ID}.npz"))
}

/// Unsafe demonstrations of `unsafe_lengths` transitions, each followed in file order by a safe
/// one of 20.
fn constructed(dir: &Path, unsafe_lengths: &[usize]) -> PathBuf {
    let meta = defender::Meta { env_id: Some(ENV_ID.into()), ..Default::default() };
    let mut set = defender::EpisodeSet::new(9, 1, meta).unwrap();
    for (i, &n) in unsafe_lengths.iter().enumerate() {
        for (len, crashed) in [(n, true), (20, false)] {
            let obs: Vec<f32> = (0..(len + 1) * 9).map(|k| (0.1 * (k + i) as f32).sin()).collect();
            let act: Vec<f32> = (0..len).map(|k| 0.5 * (0.3 * k as f32).cos()).collect();
            set.push_episode(&obs, &act, &vec![1.0; len], crashed).unwrap();
        }
    }
    let path = dir.join(format!("constructed-{}.npz", unsafe_lengths.len()));
    set.save(&path).unwrap();
    path
}

/// The CSV's rows as column -> value.
fn rows(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| header.iter().map(|h| h.to_string()).zip(l.split(',').map(str::to_string)).collect())
        .collect()
}

fn num(row: &HashMap<String, String>, column: &str) -> f64 {
    row.get(column).unwrap_or_else(|| panic!("no column {column}")).parse().unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-3
}

#[test]
fn an_untrained_critic_gives_the_known_leads_on_the_held_out_half() {
    let dir = tempfile::tempdir().unwrap();
    // Even-indexed unsafe ones (5, 9, 13 transitions) are pretrained on; odd ones (7, 11, 15)
    // are measured: leads 6, 10, 14 steps before the violating step.
    let demos = constructed(dir.path(), &[5, 7, 9, 11, 13, 15]);
    let out = dir.path().join("known.csv");
    ok(&[
        "demos",
        "risk-horizon",
        "--env",
        ENV_ID,
        "--demos",
        s(&demos),
        "--gamma-risk",
        "0.9",
        "--eps-risk",
        "0.01,0.99",
        "--pretrain-steps",
        "1",
        "--out",
        s(&out),
    ]);
    let r = rows(&out);
    assert_eq!(r.len(), 2);
    for row in &r {
        assert_eq!(row["split"], "even-odd");
        for (column, n) in
            [("train_safe", 3.0), ("train_unsafe", 3.0), ("measured_safe", 3.0), ("measured_unsafe", 3.0)]
        {
            assert_eq!(num(row, column), n, "{column}");
        }
        assert_eq!(num(row, "dt_s"), DT);
        let k = num(row, "eps_risk").ln() / 0.9f64.ln();
        assert!(close(num(row, "closed_form_steps"), k) && close(num(row, "closed_form_s"), k * DT));
    }
    let all = &r[0];
    assert_eq!(num(all, "eps_risk"), 0.01);
    for (column, v) in [
        ("never_flagged_share", 0.0),
        ("flagged_from_start_share", 1.0),
        ("first_lead_q1_steps", 8.0),
        ("first_lead_median_steps", 10.0),
        ("first_lead_q3_steps", 12.0),
        ("first_lead_q1_s", 0.4),
        ("first_lead_median_s", 0.5),
        ("first_lead_q3_s", 0.6),
        ("unflagged_at_violation_share", 0.0),
        ("held_lead_median_steps", 10.0),
        ("held_lead_q3_s", 0.6),
        ("safe_steps_flagged_share", 1.0),
        ("safe_episodes_flagged_share", 1.0),
    ] {
        assert!(close(num(all, column), v), "eps 0.01: {column} = {}, expected {v}", all[column]);
    }
    let none = &r[1];
    for (column, v) in [
        ("never_flagged_share", 1.0),
        ("unflagged_at_violation_share", 1.0),
        ("safe_steps_flagged_share", 0.0),
        ("safe_episodes_flagged_share", 0.0),
    ] {
        assert!(close(num(none, column), v), "eps 0.99: {column} = {}, expected {v}", none[column]);
    }
    assert!(num(none, "first_lead_median_steps").is_nan() && num(none, "held_lead_median_s").is_nan());
}

#[test]
fn a_pretrained_critic_flags_less_at_a_higher_eps_and_repeats_with_its_seed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "demos",
            "risk-horizon",
            "--env",
            ENV_ID,
            "--gamma-risk",
            "0.5,0.95",
            "--eps-risk",
            "0.3,0.5",
            "--pretrain-steps",
            "300",
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        ok(&args);
        out
    };
    let first = run("a.csv", &[]);
    let r = rows(&first);
    assert_eq!(r.len(), 4, "two critics, two thresholds each");
    let set = defender::EpisodeSet::load(shipped()).unwrap();
    let (safe, unsafe_) = set.group_sizes();
    for row in &r {
        assert_eq!(num(row, "train_unsafe") + num(row, "measured_unsafe"), unsafe_ as f64);
        assert_eq!(num(row, "measured_safe"), (safe / 2) as f64, "the odd-indexed half is measured");
        assert_eq!(
            (num(row, "pretrain_steps"), num(row, "pos_fraction"), num(row, "batch_size")),
            (300.0, 0.3, 256.0)
        );
        for which in ["first_lead", "held_lead"] {
            for q in ["q1", "median", "q3"] {
                let (steps, secs) =
                    (num(row, &format!("{which}_{q}_steps")), num(row, &format!("{which}_{q}_s")));
                assert!(steps.is_nan() || close(secs, steps * DT), "{which}_{q}: {steps} steps, {secs} s");
            }
        }
    }
    for pair in r.chunks(2) {
        let (low, high) = (&pair[0], &pair[1]);
        assert_eq!(
            (num(low, "gamma_risk"), num(low, "eps_risk"), num(high, "eps_risk")),
            (num(high, "gamma_risk"), 0.3, 0.5)
        );
        for column in ["never_flagged_share", "unflagged_at_violation_share"] {
            assert!(num(high, column) >= num(low, column), "{column}: {low:?} / {high:?}");
        }
        for column in ["safe_steps_flagged_share", "safe_episodes_flagged_share", "flagged_from_start_share"]
        {
            assert!(num(high, column) <= num(low, column), "{column}: {low:?} / {high:?}");
        }
        assert_eq!(low["q_at_violation_median"], high["q_at_violation_median"], "one critic per gamma");
    }
    let again = run("b.csv", &[]);
    assert_eq!(std::fs::read_to_string(&first).unwrap(), std::fs::read_to_string(&again).unwrap());
    let other = run("c.csv", &["--seeds", "1"]);
    assert_ne!(std::fs::read(&first).unwrap(), std::fs::read(&other).unwrap(), "seed 1's critic is another");
    let inside = rows(&run("d.csv", &["--in-sample"]));
    assert_eq!(
        (inside[0]["split"].as_str(), num(&inside[0], "measured_unsafe")),
        ("in-sample", unsafe_ as f64)
    );
}

#[test]
fn bad_input_is_refused_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    // Each refusal with the task and a one-step pretraining unless it gives its own.
    let refuse = |extra: &[&str], expect: &[&str]| {
        let mut args = vec!["demos", "risk-horizon", "--out", s(&out)];
        if !extra.contains(&"--env") {
            args.extend(["--env", ENV_ID]);
        }
        if !extra.contains(&"--pretrain-steps") {
            args.extend(["--pretrain-steps", "1"]);
        }
        args.extend_from_slice(extra);
        refused(&args, expect);
    };
    refuse(&["--gamma-risk", "0.9,1"], &["--gamma-risk 1", "gamma_risk", "(0, 1)"]);
    refuse(&["--eps-risk", "0"], &["--eps-risk 0", "eps_risk"]);
    refuse(&["--pos-fraction", "1"], &["pos_fraction"]);
    refuse(&["--pretrain-steps", "0"], &["--pretrain-steps 0"]);
    refuse(&["--env", "Nope-v0"], &["Nope-v0"]);
    let hopper = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/Hopper-v5.npz");
    refuse(&["--demos", s(&hopper)], &["Hopper-v5.npz"]);
    refuse(&["--demos", s(&dir.path().join("missing.npz"))], &["missing.npz"]);
    let one = constructed(dir.path(), &[5]);
    refuse(&["--demos", s(&one)], &["1 safe and 1 unsafe", "at least 2"]);
    let unwritable = dir.path().join("no/such/dir/x.csv");
    refused(&["demos", "risk-horizon", "--env", ENV_ID, "--out", s(&unwritable)], &["--out"]);
    assert!(!out.exists(), "nothing written on a refusal");
}
