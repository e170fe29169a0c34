//! The report's readings of a run beyond SPEC 6 (best training episode, mean of the last 10
//! evaluations, standing still) against hand-computed values, and the bootstrap interval against
//! an independent computation.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use common::{A, RunSpec};
use defender_report::{
    CSV_HEADER, Format, Run, Table, bootstrap_ci, bootstrap_ci_with, load_runs, percentile_ci, render,
};

fn load(dir: &std::path::Path) -> Run {
    Run::load(dir).unwrap()
}

#[test]
fn the_best_episode_is_the_maximum_over_all_training_episodes_filtered_ones_included() {
    let root = tempfile::tempdir().unwrap();
    // The best return is a filtered episode's: it counts, as in the paper's code.
    let dir =
        RunSpec::new("sac", 0, A).outcomes(4, 1, 1).returns(&[5.0, 900.0, 300.0, -20.0]).write(root.path());
    assert_eq!(load(&dir).best_episode(), Some(900.0));
    let dir =
        RunSpec::new("sac", 1, A).outcomes(4, 4, 0).returns(&[-7.5, -3.25, -10.0, -4.0]).write(root.path());
    assert_eq!(load(&dir).best_episode(), Some(-3.25), "negative returns");
    let table = Table::from_runs(&load_runs(&[root.path()]).unwrap().runs);
    let best = table.rows[0].best_episode.unwrap();
    // Seeds 0 and 1: 900 and -3.25.
    assert_eq!((best.stat.mean, best.stat.n), ((900.0 - 3.25) / 2.0, 2));
    assert_eq!((best.ci.lo, best.ci.hi), (-3.25, 900.0), "2 seeds: each drawn twice with p = 1/4");
}

#[test]
fn last_ten_evaluations_average_the_tail_or_all_of_a_short_run() {
    let root = tempfile::tempdir().unwrap();
    // 12 evaluations returning 1..=12: the last 10 are 3..=12, mean 7.5.
    let evals: Vec<(f64, f64)> = (1..=12).map(|k| (f64::from(k), 100.0)).collect();
    let dir = RunSpec::new("sac", 0, None).outcomes(12, 0, 0).evals(&evals).write(root.path());
    let run = load(&dir);
    assert_eq!(run.acc_reward(), 12.0);
    assert_eq!(run.last_evaluations(), 7.5);
    // 3 evaluations: all of them.
    let dir = RunSpec::new("sac", 1, None).evals(&[(10.0, 5.0), (20.0, 5.0), (60.0, 5.0)]).write(root.path());
    assert_eq!(load(&dir).last_evaluations(), 30.0);
}

#[test]
fn standing_is_the_share_of_evaluations_at_the_horizon_with_return_near_length() {
    let root = tempfile::tempdir().unwrap();
    // Hopper-v5 (horizon 1000): standing at 1000/1000 and 1080/1000; not at 3000/1000 (hopping),
    // 950/999 (an episode fell), 150/150 (short): 2 of 5 = 40%.
    let evals = [(1000.0, 1000.0), (1080.0, 1000.0), (3000.0, 1000.0), (950.0, 999.0), (150.0, 150.0)];
    let hopper = RunSpec::new("sac", 0, None).outcomes(5, 0, 0).evals(&evals).write(root.path());
    assert_eq!(load(&hopper).standing_pct(), Some(40.0));
    let mut idp = RunSpec::new("sac", 0, None).evals(&[(9350.0, 1000.0), (1000.0, 1000.0)]);
    idp.env = "InvertedDoublePendulum-v5";
    // Its per-step reward is ~9.3: a balanced pendulum never "stands"; 1000 over 1000 steps would.
    assert_eq!(load(&idp.write(root.path())).standing_pct(), Some(50.0));
    let mut unknown = RunSpec::new("sac", 0, None).evals(&[(1000.0, 1000.0)]);
    unknown.env = "Ant-v5";
    let unknown = unknown.write(root.path());
    assert_eq!(load(&unknown).standing_pct(), None, "no known horizon");

    let set = load_runs(&[root.path()]).unwrap();
    let table = Table::from_runs(&set.runs);
    let md = render(&table, Format::Markdown);
    let line = |env: &str| {
        let at = md.find(&format!("### {env},")).unwrap();
        let row = md[at..].lines().find(|l| l.starts_with("| SAC")).unwrap();
        row.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect::<Vec<_>>()
    };
    assert_eq!(line("Hopper-v5")[9], "40 ± 0.0 [40, 40]", "{md}");
    assert_eq!(line("Ant-v5")[9], "-", "{md}");
    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let ant: Vec<&str> = csv.lines().find(|l| l.starts_with("Ant-v5")).unwrap().split(',').collect();
    assert_eq!(ant[col("standing_pct_mean")], "");
    let hopper: Vec<&str> = csv.lines().find(|l| l.starts_with("Hopper-v5")).unwrap().split(',').collect();
    assert_eq!(hopper[col("standing_pct_mean")], "40");
}

#[test]
fn csv_has_every_reading_with_its_interval() {
    let root = tempfile::tempdir().unwrap();
    // Acc Reward 110, 110, 140 over seeds 0-2; episodes return 10 i + seed (best 30 + seed);
    // evaluations rise linearly to Acc Reward (mean of the 4: 5/8 of it).
    for (seed, acc) in [(0, 110.0), (1, 110.0), (2, 140.0)] {
        RunSpec::new("sac", seed, A).outcomes(4, usize::from(seed != 1), 1).acc(acc).write(root.path());
    }
    let csv = render(&Table::from_runs(&load_runs(&[root.path()]).unwrap().runs), Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row.len(), header.len());
    let num = |name: &str| row[header.iter().position(|h| *h == name).unwrap()].parse::<f64>().unwrap();
    // P(every draw is one of the two 110s) = 8/27 > 2.5%; P(all three are 140) = 1/27 > 2.5%.
    assert_eq!((num("acc_reward_ci_lo"), num("acc_reward_ci_hi")), (110.0, 140.0));
    assert_eq!(
        (num("best_episode_mean"), num("best_episode_ci_lo"), num("best_episode_ci_hi")),
        (31.0, 30.0, 32.0)
    );
    assert!((num("best_episode_std") - (2.0f64 / 3.0).sqrt()).abs() < 1e-12);
    assert_eq!(
        (num("last10_eval_mean"), num("last10_eval_ci_lo"), num("last10_eval_ci_hi")),
        (75.0, 68.75, 87.5)
    );
    assert_eq!((num("crash_pct_ci_lo"), num("crash_pct_ci_hi")), (0.0, 25.0));
    assert_eq!((num("standing_pct_mean"), num("standing_pct_ci_hi")), (0.0, 0.0));
}

#[test]
fn the_percentile_interval_of_hand_picked_resamples() {
    // Values 1, 2, 6 and five resamples chosen by hand; their means, sorted:
    // [0,0,0] -> 1, [0,0,1] -> 4/3, [0,1,2] -> 3, [1,1,2] -> 10/3, [2,2,2] -> 6.
    let values = [1.0, 2.0, 6.0];
    let draws = [[0, 0, 0], [0, 1, 2], [2, 2, 2], [1, 1, 2], [0, 0, 1]];
    // 50%: the 25th and 75th percentiles, at positions 1 and 3 of the 5 sorted means.
    let ci = percentile_ci(&values, draws, 0.5).unwrap();
    assert!((ci.lo - 4.0 / 3.0).abs() < 1e-12 && (ci.hi - 10.0 / 3.0).abs() < 1e-12, "{ci:?}");
    // 95%: positions 0.025 x 4 = 0.1 and 3.9, interpolated: 1 + 0.1 (4/3 - 1) and
    // 10/3 + 0.9 (6 - 10/3).
    let ci = percentile_ci(&values, draws, 0.95).unwrap();
    assert!((ci.lo - (1.0 + 0.1 / 3.0)).abs() < 1e-12, "{ci:?}");
    assert!((ci.hi - (10.0 / 3.0 + 0.9 * 8.0 / 3.0)).abs() < 1e-12, "{ci:?}");
    assert!(percentile_ci(&values, Vec::<Vec<usize>>::new(), 0.95).is_none());
    assert!(percentile_ci(&[], draws, 0.95).is_none());
}

/// The exact bootstrap distribution of the mean of 5 values (all 5^5 resamples, equally likely),
/// computed here without the crate: its 2.5% and 97.5% quantiles bracket the crate's interval
/// from 50,000 random resamples, up to the sampling error of a quantile (0.07 percentage points
/// of probability at 2.5%; the test allows 0.5).
#[test]
fn the_bootstrap_interval_matches_the_exact_bootstrap_distribution() {
    let values = [3.0, 7.0, 8.0, 15.0, 40.0];
    let mut means = Vec::new();
    for code in 0..5usize.pow(5) {
        let mut c = code;
        let mut sum = 0.0;
        for _ in 0..5 {
            sum += values[c % 5];
            c /= 5;
        }
        means.push(sum / 5.0);
    }
    means.sort_by(f64::total_cmp);
    // The exact q-quantile (inverse CDF) of the equally weighted means.
    let exact = |q: f64| means[((q * means.len() as f64).ceil() as usize).max(1) - 1];
    let ci = bootstrap_ci(&values).unwrap();
    assert!(exact(0.020) <= ci.lo && ci.lo <= exact(0.030), "{ci:?} vs {} .. {}", exact(0.02), exact(0.03));
    assert!(exact(0.970) <= ci.hi && ci.hi <= exact(0.980), "{ci:?} vs {} .. {}", exact(0.97), exact(0.98));
    assert_eq!(bootstrap_ci(&values), Some(ci), "a fixed seed: the same interval every time");
    let other_seed = bootstrap_ci_with(&values, 50_000, 7, 0.95).unwrap();
    assert!((other_seed.lo - ci.lo).abs() < 2.0 && (other_seed.hi - ci.hi).abs() < 2.0, "{other_seed:?}");
}

#[test]
fn the_bootstrap_interval_is_bounded_by_the_values_and_degenerates_as_it_should() {
    assert_eq!(bootstrap_ci(&[]), None);
    let one = bootstrap_ci(&[4.5]).unwrap();
    assert_eq!((one.lo, one.hi), (4.5, 4.5));
    let same = bootstrap_ci(&[2.0, 2.0, 2.0, 2.0]).unwrap();
    assert_eq!((same.lo, same.hi), (2.0, 2.0));
    let values = [12.0, -3.0, 8.5, 40.0, 0.0, 7.0, 7.5, 9.0];
    let ci = bootstrap_ci(&values).unwrap();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    assert!(-3.0 <= ci.lo && ci.lo < mean && mean < ci.hi && ci.hi <= 40.0, "{ci:?}");
    // Wider at 99% than at 95%, narrower at 50%.
    let wide = bootstrap_ci_with(&values, 50_000, 0, 0.99).unwrap();
    let narrow = bootstrap_ci_with(&values, 50_000, 0, 0.5).unwrap();
    assert!(wide.lo <= ci.lo && ci.hi <= wide.hi && ci.lo <= narrow.lo && narrow.hi <= ci.hi);
}

/// Coverage: over 400 samples of 10 draws from a known distribution (uniform on [0, 1], mean
/// 0.5), the 95% percentile interval holds the true mean in about 95% of them (the percentile
/// bootstrap is known to under-cover a little at n = 10, about 91-93%).
#[test]
fn the_bootstrap_interval_covers_the_true_mean_about_95_percent_of_the_time() {
    // A generator of our own (64-bit LCG, Knuth's constants), independent of the crate's.
    let mut state = 12345u64;
    let mut uniform = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let trials = 400;
    let mut covered = 0;
    for t in 0..trials {
        let sample: Vec<f64> = (0..10).map(|_| uniform()).collect();
        let ci = bootstrap_ci_with(&sample, 2_000, t, 0.95).unwrap();
        covered += usize::from(ci.lo <= 0.5 && 0.5 <= ci.hi);
    }
    let rate = covered as f64 / trials as f64;
    assert!((0.86..=0.98).contains(&rate), "coverage {rate}");
}

#[test]
fn crashes_are_counted_over_the_run_and_per_environment_step_without_filtered_steps() {
    let root = tempfile::tempdir().unwrap();
    // 10 episodes of 100 steps: 3 crashed, 5 filtered (their last step never reached the
    // environment), 2 truncated; a file without the cost column (crashes cost 1).
    let dir = RunSpec::new("sac", 0, A).outcomes(10, 3, 5).write(root.path());
    let run = load(&dir);
    let v = run.violations();
    assert_eq!((v.crashes, v.env_steps, v.cost), (3, 995, 3.0));
    assert!((v.crashes_per_1k_env_steps - 3000.0 / 995.0).abs() < 1e-12);
    // The cumulative curve: the crashes come first; each filtered episode takes a step off.
    let curve = run.cumulative_crashes();
    assert_eq!(curve[2], (300, 3));
    assert_eq!(curve[7], (795, 3));
    assert_eq!(curve[9], (995, 3));
    let table = Table::from_runs(&[run]);
    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let col = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
    assert_eq!(col("crashes_mean"), "3");
    assert_eq!(col("crash_pct_mean"), "30");
    assert!(render(&table, Format::Markdown).contains("Crashes / 1k env steps"));
}

#[test]
fn crashes_after_the_warm_up_count_the_crashed_episodes_ending_after_learning_starts() {
    let root = tempfile::tempdir().unwrap();
    // Episodes of 100 steps ending at 100, 200, ...: seed 0 crashes in its first 5 of 8 and
    // warms up for 250 steps, so the episodes ending at 300, 400 and 500 count (3); seed 1
    // crashes in its first 2, both within a warm-up of 200 (an episode ending at it is inside).
    let s0 = RunSpec::new("sac", 0, None).outcomes(8, 5, 0).warmup(250).write(root.path());
    let s1 = RunSpec::new("sac", 1, None).outcomes(8, 2, 0).warmup(200).write(root.path());
    assert_eq!(load(&s0).crashed_after_warmup(), Some(3));
    assert_eq!(load(&s1).crashed_after_warmup(), Some(0));
    let peer = RunSpec::new("td3", 0, None).outcomes(8, 5, 0).write(root.path());
    assert_eq!(load(&peer).crashed_after_warmup(), None, "a configuration without the warm-up");

    let table = Table::from_runs(&load_runs(&[root.path()]).unwrap().runs);
    let sac = table.rows.iter().find(|r| r.algo == "sac").unwrap();
    let after = sac.crashes_after_warmup.unwrap();
    assert_eq!((after.stat.mean, after.stat.n), (1.5, 2));
    assert_eq!(sac.crashes.stat.mean, 3.5, "all crashes, the warm-up's included");
    assert!(table.rows.iter().find(|r| r.algo == "td3").unwrap().crashes_after_warmup.is_none());

    let md = render(&table, Format::Markdown);
    let cells = |prefix: &str| -> Vec<String> {
        let line = md.lines().find(|l| l.starts_with(prefix)).unwrap();
        line.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect()
    };
    let header = cells("| Algorithm");
    let at = header.iter().position(|h| h == "Crashes after warm-up").unwrap();
    assert_eq!(header[at - 1], "Crashes", "{md}");
    assert_eq!(cells("| SAC")[at], "2 ± 1.5 [0, 3]", "{md}");
    assert_eq!(cells("| TD3")[at], "-", "{md}");
    let csv = render(&table, Format::Csv);
    let header: Vec<&str> = CSV_HEADER.split(',').collect();
    let col = |algo: &str, name: &str| -> String {
        let row: Vec<&str> =
            csv.lines().find(|l| l.split(',').nth(1) == Some(algo)).unwrap().split(',').collect();
        row[header.iter().position(|h| *h == name).unwrap()].to_string()
    };
    assert_eq!(col("sac", "crashes_after_warmup_mean"), "1.5");
    assert_eq!(col("sac", "crashes_after_warmup_ci_hi"), "3");
    assert_eq!(col("td3", "crashes_after_warmup_mean"), "");
}
