//! The table's numbers against hand-computed values, and its three renderings.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use common::{A, B, RunSpec, paper_fixture};
use defender::Mode;
use defender_report::{CSV_HEADER, Format, Row, SkipKind, Stat, Table, load_runs, render};
use defender_rl::Budget;

fn close(stat: &Stat, mean: f64, std: f64) -> bool {
    (stat.mean - mean).abs() < 1e-9 && (stat.std - std).abs() < 1e-9
}

fn table_of(root: &std::path::Path) -> Table {
    let set = load_runs(&[root]).unwrap();
    assert!(set.skipped.is_empty());
    Table::from_runs(&set.runs)
}

fn row<'t>(table: &'t Table, algo: &str, strategy: Option<&str>) -> &'t Row {
    table
        .rows
        .iter()
        .find(|r| r.algo == algo && r.filter.as_ref().map(|f| f.strategy.as_str()) == strategy)
        .unwrap()
}

#[test]
fn numbers_match_hand_computed_values() {
    let dir = tempfile::tempdir().unwrap();
    paper_fixture(dir.path());
    let table = table_of(dir.path());
    assert_eq!(table.rows.len(), 6);
    assert!(table.notes.is_empty(), "{:?}", table.notes);

    // Order: per algorithm, bare first, then strategies by name.
    let order: Vec<(String, Option<String>)> =
        table.rows.iter().map(|r| (r.algo.clone(), r.filter.as_ref().map(|f| f.strategy.clone()))).collect();
    let s = |x: &str| Some(x.to_string());
    assert_eq!(
        order,
        vec![
            ("sac".into(), None),
            ("sac".into(), s("MeanDemoW5/MeanDemoW10")),
            ("sac".into(), s("MinDemoW5/MinDemoW10")),
            ("td3".into(), None),
            ("td3".into(), s("MeanDemoW5/MeanDemoW10")),
            ("td3".into(), s("MinDemoW5/MinDemoW10")),
        ]
    );

    // SAC bare: acc 100, 200, 300 -> 200 +- sqrt(20000/3); crash 50, 25, 75 -> 50 +- sqrt(1250/3).
    let r = row(&table, "sac", None);
    assert_eq!(r.seeds, vec![0, 1, 2]);
    assert_eq!(r.budget, Budget::Steps(400));
    assert!(close(&r.acc_reward.stat, 200.0, (20000.0f64 / 3.0).sqrt()), "{:?}", r.acc_reward);
    assert!(close(&r.crash_pct.stat, 50.0, (1250.0f64 / 3.0).sqrt()), "{:?}", r.crash_pct);
    assert!(close(&r.filtered_pct, 0.0, 0.0));
    assert!(close(&r.time_pct.unwrap(), 100.0, 0.0));

    // SAC A: acc 110, 110, 140 -> 120 +- sqrt(200); crash 25, 0, 25 -> 50/3 +- sqrt(1250/9);
    // filtered 25, 50, 25; time 15/10, 30/20, 40/40 -> 150, 150, 100 -> 400/3 +- sqrt(5000/9).
    let r = row(&table, "sac", Some("MeanDemoW5/MeanDemoW10"));
    let f = r.filter.as_ref().unwrap();
    assert_eq!(
        (f.safe(), f.unsafe_(), f.mode, f.num_demos),
        ("MeanDemoW5", "MeanDemoW10", Mode::State, Some(50))
    );
    assert!(close(&r.acc_reward.stat, 120.0, 200.0f64.sqrt()));
    assert!(close(&r.crash_pct.stat, 50.0 / 3.0, (1250.0f64 / 9.0).sqrt()));
    assert!(close(&r.filtered_pct, 100.0 / 3.0, (1250.0f64 / 9.0).sqrt()));
    assert!(close(&r.time_pct.unwrap(), 400.0 / 3.0, (5000.0f64 / 9.0).sqrt()));
    assert_eq!(r.time_pct.unwrap().n, 3);

    // SAC B: always -4, no crash, all filtered, twice the bare's time.
    let r = row(&table, "sac", Some("MinDemoW5/MinDemoW10"));
    assert!(close(&r.acc_reward.stat, -4.0, 0.0));
    assert!(close(&r.crash_pct.stat, 0.0, 0.0));
    assert!(close(&r.filtered_pct, 100.0, 0.0));
    assert!(close(&r.time_pct.unwrap(), 200.0, 0.0));

    // TD3 bare: acc 50, 60, 70 -> 60 +- sqrt(200/3); crash 80, 80, 40 -> 200/3 +- sqrt(3200/9).
    let r = row(&table, "td3", None);
    assert!(close(&r.acc_reward.stat, 60.0, (200.0f64 / 3.0).sqrt()));
    assert!(close(&r.crash_pct.stat, 200.0 / 3.0, (3200.0f64 / 9.0).sqrt()));
    let r = row(&table, "td3", Some("MeanDemoW5/MeanDemoW10"));
    assert!(close(&r.acc_reward.stat, 80.0, 0.0));
    assert!(close(&r.crash_pct.stat, 20.0, 0.0));
    assert!(close(&r.time_pct.unwrap(), 150.0, 0.0));
    let r = row(&table, "td3", Some("MinDemoW5/MinDemoW10"));
    assert!(close(&r.time_pct.unwrap(), 300.0, 0.0));
    assert!(close(&r.wall_seconds, 300.0, 0.0));
}

#[test]
fn missing_bare_runs_leave_time_out_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    // SAC: bare for seed 0 only; A for seeds 0 and 1 -> % Time over seed 0 only.
    RunSpec::new("sac", 0, None).wall(10.0).write(dir.path());
    RunSpec::new("sac", 0, A).wall(12.0).write(dir.path());
    RunSpec::new("sac", 1, A).wall(50.0).write(dir.path());
    // TD3: no bare run at all -> "-".
    RunSpec::new("td3", 0, B).write(dir.path());
    let table = table_of(dir.path());
    let a = row(&table, "sac", Some("MeanDemoW5/MeanDemoW10"));
    assert!(close(&a.time_pct.unwrap(), 120.0, 0.0));
    assert_eq!(a.time_pct.unwrap().n, 1);
    assert_eq!(row(&table, "td3", Some("MinDemoW5/MinDemoW10")).time_pct, None);
    assert_eq!(
        table.notes,
        vec![
            "% Time of Hopper-v5 SAC MeanDemoW5/MeanDemoW10 (state, 400 steps): no bare run for seed(s) 1; \
             averaged over the other 1 seed(s)."
                .to_string(),
            "% Time of Hopper-v5 TD3 MinDemoW5/MinDemoW10 (state, 400 steps): no bare run for seed(s) 0; \
             shown as -."
                .to_string(),
        ]
    );
    let md = render(&table, Format::Markdown);
    let td3_line = md.lines().find(|l| l.starts_with("| TD3")).unwrap();
    let td3_cells: Vec<&str> = td3_line.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
    assert_eq!(td3_cells[11..], ["-", "1"], "{md}");
    assert!(md.contains("Notes:\n- % Time of Hopper-v5 SAC"), "{md}");
    let csv = render(&table, Format::Csv);
    let td3 = csv.lines().find(|l| l.starts_with("Hopper-v5,td3")).unwrap();
    let fields: Vec<&str> = td3.split(',').collect();
    assert_eq!(&fields[17..20], &["", "", "0"]);
}

#[test]
fn markdown_is_grouped_like_the_paper() {
    let dir = tempfile::tempdir().unwrap();
    paper_fixture(dir.path());
    let md = render(&table_of(dir.path()), Format::Markdown);
    assert!(md.starts_with("# DEFENDER report\n\n## State trajectories (as the paper's Table 1)\n"), "{md}");
    let cells =
        |l: &str| l.split('|').map(str::trim).filter(|c| !c.is_empty()).map(String::from).collect::<Vec<_>>();
    let headers: Vec<&str> = md.lines().filter(|l| l.starts_with("| Algorithm")).collect();
    assert_eq!(headers.len(), 2, "two tables (400 and 500 steps): {md}");
    assert_eq!(
        cells(headers[0]),
        [
            "Algorithm",
            "Safe",
            "Unsafe",
            "Acc Reward (final eval)",
            "Best episode (paper's Acc Reward)",
            "Last-10 eval",
            "% Crash",
            "Crashes",
            "Filtered (interventions)",
            "Crashes / 1k env steps",
            "Standing %",
            "% Time",
            "Seeds"
        ]
    );
    let all: Vec<Vec<String>> = md
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| -") && !l.starts_with("| Algorithm"))
        .map(cells)
        .collect();
    assert_eq!(all.len(), 6);
    // By hand (common/mod.rs): episode i of seed s returns 10 i + s, so the best of 4 episodes is
    // 30 + s and of 5, 40 + s; the evaluations rise linearly to Acc Reward, so the mean of all
    // of them (fewer than 10) is 5/8 of it over 4 evaluations and 6/10 over 5; every evaluation
    // lasts 100 steps, short of Hopper's horizon: never standing. With 3 seeds, each drawn
    // thrice with probability 1/27 > 2.5%, the bootstrap interval is [min, max] of the seeds.
    // (Rust rounds halves to even: 62.5 -> 62, 187.5 -> 188.)
    assert_eq!(
        all[0],
        [
            "SAC",
            "-",
            "-",
            "200 ± 81.6 [100, 300]",
            "31 ± 0.8 [30, 32]",
            "125 ± 51.0 [62, 188]",
            "50.0 ± 20.4 [25.0, 75.0]",
            "2 ± 0.8 [1, 3]",
            "-",
            "5.00 ± 2.0 [2.50, 7.50]",
            "0 ± 0.0 [0, 0]",
            "100",
            "3"
        ]
    );
    assert_eq!(
        all[1],
        [
            "SAC",
            "MeanDemoW5",
            "MeanDemoW10",
            "120 ± 14.1 [110, 140]",
            "31 ± 0.8 [30, 32]",
            "75 ± 8.8 [69, 88]",
            "16.7 ± 11.8 [0.0, 25.0]",
            "1 ± 0.5 [0, 1]",
            // Filtered 1, 2, 1 of 4 episodes: 4/3 ± sqrt(2/9).
            "1 ± 0.5 [1, 2]",
            "1.67 ± 1.2 [0.00, 2.51]",
            "0 ± 0.0 [0, 0]",
            "133",
            "3"
        ]
    );
    assert_eq!(all[2][3..6], ["-4 ± 0.0 [-4, -4]", "31 ± 0.8 [30, 32]", "-2 ± 0.0 [-2, -2]"]);
    assert_eq!(
        all[3],
        [
            "TD3",
            "-",
            "-",
            "60 ± 8.2 [50, 70]",
            "41 ± 0.8 [40, 42]",
            "36 ± 4.9 [30, 42]",
            "66.7 ± 18.9 [40.0, 80.0]",
            "3 ± 0.9 [2, 4]",
            "-",
            "6.67 ± 1.9 [4.00, 8.00]",
            "0 ± 0.0 [0, 0]",
            "100",
            "3"
        ]
    );
    assert_eq!(all[5][..4], ["TD3", "MinDemoW5", "MinDemoW10", "10 ± 0.0 [10, 10]"]);
    // TD3 B: every one of the 5 episodes filtered.
    assert_eq!(all[5][8], "5 ± 0.0 [5, 5]");
    assert_eq!(all[5][11..], ["300", "3"]);
    assert!(md.contains("### Hopper-v5, 400 steps\n") && md.contains("### Hopper-v5, 500 steps\n"));
    assert!(md.contains("population std, ddof = 0"));
    assert!(md.contains("95% percentile bootstrap confidence interval"), "{md}");
    // Padded: every line of a table has the same width.
    let widths: Vec<usize> = md
        .lines()
        .take_while(|l| !l.contains("500 steps"))
        .filter(|l| l.starts_with('|'))
        .map(|l| l.chars().count())
        .collect();
    assert!(widths.windows(2).all(|w| w[0] == w[1]), "{widths:?}\n{md}");
}

#[test]
fn latex_is_booktabs_with_tasks_side_by_side() {
    let dir = tempfile::tempdir().unwrap();
    paper_fixture(dir.path());
    // A second task and a state-action run make two column groups and two tables.
    let mut walker = RunSpec::new("sac", 0, None).acc(3000.0);
    walker.env = "Walker2d-v5";
    walker.write(dir.path());
    RunSpec::new("sac", 0, Some(("MinBoth", "state-action"))).write(dir.path());
    let set = load_runs(&[dir.path()]);
    // "MinBoth" is not SAFE/UNSAFE: the contract says strategy = "SAFE/UNSAFE".
    let err = set.unwrap_err().to_string();
    assert!(err.contains("expected SAFE/UNSAFE"), "{err}");
    std::fs::remove_dir_all(dir.path().join("hopper-v5_sac_minboth_state-action_s0")).unwrap();
    RunSpec::new("sac", 0, Some(("MinBoth/MinTrajW10", "state-action"))).write(dir.path());

    let tex = render(&table_of(dir.path()), Format::Latex);
    assert_eq!(tex.matches("\\begin{table}").count(), 2, "{tex}");
    assert_eq!(tex.matches("\\toprule").count(), 2);
    assert_eq!(tex.matches("\\bottomrule").count(), 2);
    assert!(tex.contains("state trajectories (as the paper's Table 1)"));
    assert!(tex.contains("state-action trajectories (as the paper's Table 2)"));
    // Hopper-v5 has two budgets (400 and 500 steps), Walker2d-v5 one: three column groups.
    // Five columns per group: both rewards, % Crash, crashes, % Time; and the filtered
    // episodes beside the crashes where a row has a filter (Hopper-v5's, not Walker2d-v5's).
    assert!(tex.contains(&format!("\\begin{{tabular}}{{ll{}}}", "r".repeat(17))), "{tex}");
    assert!(tex.contains("& \\multicolumn{6}{c}{Hopper-v5 (400 steps)} & \\multicolumn{6}{c}{Hopper-v5 (500 steps)} & \\multicolumn{5}{c}{Walker2d-v5}"), "{tex}");
    assert!(tex.contains("\\cmidrule(lr){3-8} \\cmidrule(lr){9-14} \\cmidrule(lr){15-19}"), "{tex}");
    assert!(tex.contains(
        "Safe & Unsafe & Acc Reward (final eval) & Best episode & \\% Crash & Crashes & Filtered & \\% Time & \
         Acc Reward (final eval) & Best episode & \\% Crash & Crashes & Filtered & \\% Time & \
         Acc Reward (final eval) & Best episode & \\% Crash & Crashes & \\% Time \\\\"
    ), "{tex}");
    assert!(tex.contains("Best episode: the best training-episode return of a run (the paper's Acc Reward)"));
    assert!(tex.contains("\\multicolumn{2}{l}{SAC} & 200$\\pm$81.6 & 31$\\pm$0.8 & 50$\\pm$20.4 & 2$\\pm$0.8 & - & 100 & - & - & - & - & - & - & 3000$\\pm$0.0 & 30$\\pm$0.0 & 0$\\pm$0.0 & 0$\\pm$0.0 & 100 \\\\"), "{tex}");
    assert!(
        tex.contains(
            "MeanDemoW5 & MeanDemoW10 & 120$\\pm$14.1 & 31$\\pm$0.8 & 17$\\pm$11.8 & 1$\\pm$0.5 & 1$\\pm$0.5 & 133 & - & - & - & - & - & - & - & - & - & - & - \\\\"
        ),
        "{tex}"
    );
    assert!(
        tex.contains(
            "MinBoth & MinTrajW10 & 100$\\pm$0.0 & 30$\\pm$0.0 & 0$\\pm$0.0 & 0$\\pm$0.0 & 0$\\pm$0.0 & 100 &"
        ),
        "{tex}"
    );
    // The state-action table does not list the state strategies.
    let second = &tex[tex.rfind("\\begin{table}").unwrap()..];
    assert!(!second.contains("MeanDemoW5"));
    assert!(second.contains("\\multicolumn{2}{l}{TD3}"));
}

#[test]
fn csv_has_one_row_per_group_with_mean_and_std() {
    let dir = tempfile::tempdir().unwrap();
    paper_fixture(dir.path());
    let csv = render(&table_of(dir.path()), Format::Csv);
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, CSV_HEADER.split(',').collect::<Vec<_>>());
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 6);
    assert!(rows.iter().all(|r| r.len() == header.len()));
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let a = &rows[1];
    assert_eq!(a[col("env")], "Hopper-v5");
    assert_eq!(a[col("algo")], "sac");
    assert_eq!(a[col("budget_steps")], "400");
    assert_eq!(a[col("budget_episodes")], "");
    assert_eq!(a[col("strategy")], "MeanDemoW5/MeanDemoW10");
    assert_eq!((a[col("safe")], a[col("unsafe")], a[col("mode")]), ("MeanDemoW5", "MeanDemoW10", "state"));
    assert_eq!((a[col("num_demos")], a[col("n_seeds")], a[col("seeds")]), ("50", "3", "0;1;2"));
    let num = |r: &Vec<&str>, name: &str| r[col(name)].parse::<f64>().unwrap();
    assert_eq!(num(a, "acc_reward_mean"), 120.0);
    assert!((num(a, "acc_reward_std") - 200.0f64.sqrt()).abs() < 1e-12);
    assert!((num(a, "crash_pct_mean") - 50.0 / 3.0).abs() < 1e-12);
    assert!((num(a, "time_pct_mean") - 400.0 / 3.0).abs() < 1e-12);
    assert_eq!(num(a, "time_pct_seeds"), 3.0);
    let bare = &rows[0];
    assert_eq!((bare[col("strategy")], bare[col("mode")]), ("", ""));
    assert_eq!(num(bare, "time_pct_mean"), 100.0);
    assert_eq!(num(bare, "filtered_pct_mean"), 0.0);
}

#[test]
fn incomplete_runs_are_skipped_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, None).write(dir.path());
    let running = RunSpec::new("sac", 1, None).write(dir.path());
    // A run in progress: only the summary says so; its other files may be partial.
    std::fs::write(running.join("summary.json"), "{\"env\": \"Hopper-v5\", \"complete\": false}").unwrap();
    std::fs::remove_file(running.join("eval.csv")).unwrap();
    let set = load_runs(&[dir.path()]).unwrap();
    assert_eq!(set.runs.len(), 1);
    assert_eq!(set.skipped.len(), 1);
    assert_eq!(set.skipped[0].dir, running);
    // No process holds its lock and it has no checkpoint (tests/skipped.rs has the other states).
    assert_eq!(set.skipped[0].kind, SkipKind::Broken);
    assert!(set.skipped[0].reason.contains("summary.json says \"complete\": false"), "{:?}", set.skipped);
    assert_eq!(Table::from_runs(&set.runs).rows[0].seeds, vec![0]);
}

#[test]
fn budgets_in_episodes_and_modes_are_kept_apart() {
    let dir = tempfile::tempdir().unwrap();
    let run = RunSpec::new("sac", 0, None).write(dir.path());
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    std::fs::write(
        run.join("config.toml"),
        config.replace("total_steps = 400\ntotal_episodes = 0", "total_steps = 0\ntotal_episodes = 4"),
    )
    .unwrap();
    RunSpec::new("sac", 0, Some(("MeanBothW5/MeanBothW5", "state-action"))).write(dir.path());
    let table = table_of(dir.path());
    assert_eq!(row(&table, "sac", None).budget, Budget::Episodes(4));
    assert_eq!(table.modes(), vec![Mode::StateAction]);
    // Different budgets: the state-action run has no bare run with the same budget.
    let filtered = row(&table, "sac", Some("MeanBothW5/MeanBothW5"));
    assert_eq!((filtered.budget, filtered.time_pct), (Budget::Steps(400), None));
    let md = render(&table, Format::Markdown);
    assert!(md.contains("### Hopper-v5, 4 episodes") && md.contains("### Hopper-v5, 400 steps"), "{md}");
}

#[test]
fn runs_with_different_numbers_of_demonstrations_are_separate_rows() {
    let dir = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, None).write(dir.path());
    RunSpec::new("sac", 0, A).acc(50.0).write(dir.path());
    let ten = dir.path().join("ten");
    let run = RunSpec::new("sac", 0, A).acc(30.0).write(&ten);
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    std::fs::write(run.join("config.toml"), config.replace("num_demos = 50", "num_demos = 10")).unwrap();
    let table = table_of(dir.path());
    assert!(table.varies_num_demos());
    let demos: Vec<Option<u64>> =
        table.rows.iter().map(|r| r.filter.as_ref().and_then(|f| f.num_demos)).collect();
    assert_eq!(demos, vec![None, Some(10), Some(50)]);
    let md = render(&table, Format::Markdown);
    let header = md.lines().find(|l| l.starts_with("| Algorithm")).unwrap();
    assert!(header.contains("| Demos |"), "{md}");
    let rows: Vec<Vec<&str>> = md
        .lines()
        .filter(|l| l.starts_with("| SAC"))
        .map(|l| l.split('|').map(str::trim).filter(|c| !c.is_empty()).collect())
        .collect();
    assert_eq!(rows[0][..5], ["SAC", "-", "-", "-", "100 ± 0.0 [100, 100]"]);
    assert_eq!(rows[1][..5], ["SAC", "MeanDemoW5", "MeanDemoW10", "10", "30 ± 0.0 [30, 30]"]);
    assert_eq!(rows[2][..5], ["SAC", "MeanDemoW5", "MeanDemoW10", "50", "50 ± 0.0 [50, 50]"]);
    assert!(render(&table, Format::Latex).contains("Safe & Unsafe & Demos & Acc Reward"));
}

/// Runs on z-scored DTW (`[defender.cost] scaling = "zscore"`) are a configuration of their own:
/// a row apart from the same strategy on plain DTW, labelled `z-score: `.
#[test]
fn zscore_runs_form_rows_of_their_own() {
    let root = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, A).outcomes(4, 2, 1).write(&root.path().join("plain"));
    let dir = RunSpec::new("sac", 0, A).outcomes(4, 0, 3).write(&root.path().join("zscore"));
    let config = dir.join("config.toml");
    let text = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, format!("{text}\n[defender.cost]\nscaling = \"zscore\"\n")).unwrap();
    let table = table_of(root.path());
    let rows: Vec<&Row> = table.rows.iter().filter(|r| r.filter.is_some()).collect();
    assert_eq!(rows.len(), 2, "one row per DTW");
    let labels: Vec<String> = rows.iter().map(|r| r.filter.as_ref().unwrap().name()).collect();
    assert!(labels.contains(&A.unwrap().0.to_string()), "{labels:?}");
    assert!(labels.contains(&format!("z-score: {}", A.unwrap().0)), "{labels:?}");
    let zscore = rows.iter().find(|r| r.filter.as_ref().unwrap().zscore).unwrap();
    assert!(close(&zscore.crash_pct.stat, 0.0, 0.0), "{:?}", zscore.crash_pct);
    let markdown = render(&table, Format::Markdown);
    assert!(markdown.contains("z-score: "), "{markdown}");
}

#[test]
fn an_arm_without_a_bare_run_of_its_own_label_is_timed_against_the_algorithm() {
    // An arm whose label names its filter options (`sac (demos+BC, margin0.02)`) has no bare run
    // of that label; its agent is SAC's, so bare SAC of the same seed is its yardstick.
    let root = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, None).wall(10.0).write(root.path());
    let dir = RunSpec::new("sac", 0, A).wall(15.0).write(root.path());
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    std::fs::write(
        dir.join("config.toml"),
        format!(
            "{config}\n[defender.filter]\nmargin = 0.02\n[sac]\ndemos_in_replay = true\nbc_weight = 1.0\n"
        ),
    )
    .unwrap();
    let table = Table::from_runs(&load_runs(&[root.path()]).unwrap().runs);
    let arm = table.rows.iter().find(|r| r.algo != "sac").unwrap();
    assert_eq!(arm.algo, "sac (demos+BC, margin0.02)");
    assert!(close(&arm.time_pct.unwrap(), 150.0, 0.0), "{:?}", arm.time_pct);
}

#[test]
fn a_baseline_without_the_filter_is_timed_against_plain_bare_sac() {
    // A penalty arm is its own row without a filter; timed against itself it would read 100
    // whatever its networks cost. Plain bare SAC of the same seed is its yardstick.
    let root = tempfile::tempdir().unwrap();
    RunSpec::new("sac", 0, None).wall(10.0).write(root.path());
    let dir = RunSpec::new("sac", 0, None).wall(25.0).write(&root.path().join("penalty"));
    let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    std::fs::write(
        dir.join("config.toml"),
        format!("{config}\n[safety]\nmethod = \"penalty\"\npenalty = 1.0\n"),
    )
    .unwrap();
    let table = Table::from_runs(&load_runs(&[root.path()]).unwrap().runs);
    let arm = table.rows.iter().find(|r| r.algo != "sac").unwrap();
    assert_eq!(arm.algo, "sac (penalty 1)");
    assert!(close(&arm.time_pct.unwrap(), 250.0, 0.0), "{:?}", arm.time_pct);
    let bare = table.rows.iter().find(|r| r.algo == "sac").unwrap();
    assert!(close(&bare.time_pct.unwrap(), 100.0, 0.0), "{:?}", bare.time_pct);
}
