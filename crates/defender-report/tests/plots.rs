//! Plots: written as non-empty PNG and SVG, one set per task x algorithm.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns

mod common;

use common::{A, RunSpec, paper_fixture};
use defender_report::{PlotOptions, draw_plots, load_runs};

#[test]
fn plots_are_written_as_png_and_svg() {
    let root = tempfile::tempdir().unwrap();
    paper_fixture(&root.path().join("runs"));
    let set = load_runs(&[root.path().join("runs")]).unwrap();
    let out = root.path().join("plots/nested");
    let plots = draw_plots(&set.runs, &out, &PlotOptions::default()).unwrap();
    assert!(plots.notes.is_empty(), "{:?}", plots.notes);
    let mut names: Vec<String> =
        plots.files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    names.sort();
    let mut expected = Vec::new();
    for algo in ["sac", "td3"] {
        for kind in ["crash", "crashes", "crashes_vs_eval", "eval", "return", "tradeoff", "windows"] {
            for ext in ["png", "svg"] {
                expected.push(format!("Hopper-v5_{algo}_{kind}.{ext}"));
            }
        }
    }
    assert_eq!(names, expected);
    let mut on_disk: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    assert_eq!(on_disk, expected, "no temporary file is left behind");
    for path in &plots.files {
        let bytes = std::fs::read(path).unwrap();
        if path.extension().unwrap() == "png" {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
            // IHDR: width and height, big-endian; the two-panel figure is twice as wide.
            let wide = path.to_string_lossy().contains("windows");
            assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), if wide { 1920 } else { 960 });
            assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 600);
            assert!(bytes.len() > 10_000, "{} is only {} bytes", path.display(), bytes.len());
        } else {
            let text = String::from_utf8(bytes).unwrap();
            assert!(text.contains("<svg") && text.trim_end().ends_with("</svg>"), "{}", path.display());
            if ["tradeoff", "windows", "crashes_vs_eval"].iter().any(|k| path.to_string_lossy().contains(k)) {
                continue; // below
            }
            // Title, axis label and legend entries are there as text.
            assert!(text.contains("environment steps"));
            assert!(text.contains("(bare) [3 seeds]"), "{}", path.display());
            assert!(text.contains("MeanDemoW5/MeanDemoW10 [3 seeds]"));
            assert!(text.contains("MinDemoW5/MinDemoW10 [3 seeds]"));
            assert!(text.contains("<polygon"), "shaded band");
        }
    }
    let svg = std::fs::read_to_string(out.join("Hopper-v5_sac_crash.svg")).unwrap();
    assert!(svg.contains("Hopper-v5, SAC, 400 steps: cumulative crash rate"));
    assert!(svg.contains("crashed episodes so far (%)"));

    // The trade-off: one point per configuration, in the curves' colours, and the target corner
    // (shaded) when there is a bare run with a positive Acc Reward.
    let svg = std::fs::read_to_string(out.join("Hopper-v5_sac_tradeoff.svg")).unwrap();
    assert!(svg.contains("Hopper-v5, SAC, 400 steps: final results"), "{svg}");
    assert!(svg.contains("% Crash") && svg.contains("Acc Reward"));
    for label in ["(bare) [3 seeds]", "MeanDemoW5/MeanDemoW10 [3 seeds]", "MinDemoW5/MinDemoW10 [3 seeds]"] {
        assert!(svg.contains(label), "{label}");
    }
    let crash = std::fs::read_to_string(out.join("Hopper-v5_sac_crash.svg")).unwrap();
    let colour_of = |svg: &str, label: &str| {
        // plotters writes each legend entry's marker just before its text.
        let at = svg.find(label).unwrap();
        let before = &svg[..at];
        let fill = before.rfind("stroke=\"#").or_else(|| before.rfind("fill=\"#")).unwrap();
        before[fill..fill + 16].split('#').nth(1).unwrap()[..6].to_string()
    };
    assert_eq!(
        colour_of(&svg, "MinDemoW5/MinDemoW10 [3 seeds]"),
        colour_of(&crash, "MinDemoW5/MinDemoW10 [3 seeds]"),
        "a strategy has one colour in every figure"
    );
    assert!(svg.contains("at least") || svg.contains("90% of its Acc Reward"), "the target corner's legend");

    // The long-budget view: the rolling crash rate (default window: a tenth of the 400 steps the
    // runs reach) beside the evaluation return, each with every configuration.
    let svg = std::fs::read_to_string(out.join("Hopper-v5_sac_windows.svg")).unwrap();
    assert!(svg.contains("Hopper-v5, SAC, 400 steps: crash rate and evaluation return"), "{svg}");
    assert!(svg.contains("crash rate over the last 40 steps") && svg.contains("evaluation return"));
    for label in ["(bare) [3 seeds]", "MeanDemoW5/MeanDemoW10 [3 seeds]", "MinDemoW5/MinDemoW10 [3 seeds]"] {
        assert_eq!(svg.matches(label).count(), 2, "{label} in both panels' legends");
    }
    assert_eq!(svg.matches("<svg").count(), 1, "one document");
    assert!(svg.trim_end().ends_with("</svg>"));
}

#[test]
fn the_crash_window_can_be_set() {
    let root = tempfile::tempdir().unwrap();
    paper_fixture(root.path());
    let set = load_runs(&[root.path()]).unwrap();
    let options = PlotOptions { crash_window: Some(200), ..PlotOptions::default() };
    let plots = draw_plots(&set.runs, root.path().join("p"), &options).unwrap();
    assert!(plots.notes.is_empty(), "{:?}", plots.notes);
    let svg = std::fs::read_to_string(root.path().join("p/Hopper-v5_sac_windows.svg")).unwrap();
    assert!(svg.contains("crash rate over the last 200 steps"), "{svg}");
    // A window longer than the runs: no curve, a note, and no file.
    let options = PlotOptions { crash_window: Some(10_000), ..PlotOptions::default() };
    let plots = draw_plots(&set.runs, root.path().join("q"), &options).unwrap();
    assert!(!root.path().join("q/Hopper-v5_sac_windows.svg").exists());
    assert!(
        plots.notes.iter().any(|n| n.contains("Hopper-v5_sac_windows") && n.contains("not drawn")),
        "{:?}",
        plots.notes
    );
}

#[test]
fn a_single_episode_run_is_drawn_with_markers() {
    let root = tempfile::tempdir().unwrap();
    // One DEFENDER run, one episode, one evaluation: single points are drawn as markers.
    RunSpec::new("sac", 0, A).outcomes(1, 1, 0).write(root.path());
    let set = load_runs(&[root.path()]).unwrap();
    let plots = draw_plots(&set.runs, root.path().join("p"), &PlotOptions::default()).unwrap();
    assert_eq!(plots.files.len(), 14);
    assert!(plots.notes.is_empty());
    let svg = std::fs::read_to_string(root.path().join("p/Hopper-v5_sac_eval.svg")).unwrap();
    assert!(svg.contains("<circle"), "{svg}");
    // The seed's (crashes, last-10 evaluation) point and the arm's mean ring.
    let svg = std::fs::read_to_string(root.path().join("p/Hopper-v5_sac_crashes_vs_eval.svg")).unwrap();
    assert!(svg.matches("<circle").count() >= 2, "{svg}");
}

#[test]
fn the_arms_of_an_experiment_share_one_plot_per_task() {
    // Bare SAC, and the same strategy with the default profile's filter and learner: one set of
    // files named for the algorithm, one curve each, labelled with what sets the arm apart.
    let root = tempfile::tempdir().unwrap();
    for seed in 0..2 {
        RunSpec::new("sac", seed, None).outcomes(6, 5, 0).write(root.path());
        let dir = RunSpec::new("sac", seed, A).outcomes(6, 1, 4).write(root.path());
        let arm = root.path().join(format!("arm-s{seed}"));
        std::fs::rename(&dir, &arm).unwrap();
        let config = std::fs::read_to_string(arm.join("config.toml")).unwrap();
        std::fs::write(
            arm.join("config.toml"),
            format!(
                "profile = \"keeps-learning\"\n{config}\n[defender.filter]\nmargin = 0.02\n\
                 [defender.filter.own_episodes]\nkeep = 50\n[sac]\ndemos_in_replay = true\nbc_weight = 1.0\n"
            ),
        )
        .unwrap();
    }
    let set = load_runs(&[root.path()]).unwrap();
    let plots = draw_plots(&set.runs, root.path().join("p"), &PlotOptions::default()).unwrap();
    assert_eq!(plots.files.len(), 14, "{:?}", plots.files);
    assert!(
        plots.files.iter().all(|p| p.file_name().unwrap().to_string_lossy().starts_with("Hopper-v5_sac_"))
    );
    let svg = std::fs::read_to_string(root.path().join("p/Hopper-v5_sac_crash.svg")).unwrap();
    assert!(svg.contains("SAC (bare) [2 seeds]"), "{svg}");
    assert!(svg.contains(&format!("{}, keeps-learning [2 seeds]", A.unwrap().0)), "{svg}");
}

#[test]
fn a_cost_task_gets_the_cost_plots_and_a_crash_task_does_not() {
    let root = tempfile::tempdir().unwrap();
    let env = "SafetyHopperVelocity-v1";
    for seed in 0..2 {
        RunSpec::new("sac", seed, None)
            .env(env)
            .outcomes(3, 0, 0)
            .costs(&[30.0, 10.0 * seed as f64, 0.0])
            .eval_costs(&[40.0, 20.0, 5.0 + seed as f64])
            .write(&root.path().join("runs"));
    }
    RunSpec::new("sac", 0, None).outcomes(3, 1, 0).write(&root.path().join("runs"));
    let set = load_runs(&[root.path().join("runs")]).unwrap();
    let options = PlotOptions { cost_limits: [(env, 25.0)].into_iter().collect(), ..PlotOptions::default() };
    let plots = draw_plots(&set.runs, root.path().join("p"), &options).unwrap();
    assert!(plots.notes.is_empty(), "{:?}", plots.notes);
    let names: Vec<String> =
        plots.files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    for kind in ["cost", "eval_cost"] {
        for ext in ["png", "svg"] {
            let name = format!("{env}_sac_{kind}.{ext}");
            assert!(names.contains(&name), "{name} in {names:?}");
            let bytes = std::fs::read(root.path().join("p").join(&name)).unwrap();
            assert!(bytes.len() > 10_000, "{name} is only {} bytes", bytes.len());
        }
        assert!(!names.iter().any(|n| n.starts_with(&format!("Hopper-v5_sac_{kind}."))), "{names:?}");
    }
    assert_eq!(names.len(), 14 + 18, "the crash task's 7 figures, the cost task's 9, each twice");
    let svg = std::fs::read_to_string(root.path().join(format!("p/{env}_sac_cost.svg"))).unwrap();
    assert!(svg.contains("cumulative cost against environment steps"), "{svg}");
    assert!(svg.contains("training cost so far") && svg.contains("SAC (bare) [2 seeds]"));
    assert!(svg.contains("<polygon"), "the band between the seeds");
    let svg = std::fs::read_to_string(root.path().join(format!("p/{env}_sac_eval_cost.svg"))).unwrap();
    assert!(svg.contains("evaluation cost") && svg.contains("mean evaluation episode cost"), "{svg}");
    assert!(svg.contains("episode cost limit (25)"), "the limit's legend entry: {svg}");
    assert!(svg.contains("<circle"), "evaluations are marked");
}
