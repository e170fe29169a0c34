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
        for kind in ["crash", "eval", "return", "tradeoff"] {
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
            // IHDR: width and height, big-endian.
            assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 960);
            assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 600);
            assert!(bytes.len() > 10_000, "{} is only {} bytes", path.display(), bytes.len());
        } else {
            let text = String::from_utf8(bytes).unwrap();
            assert!(text.contains("<svg") && text.trim_end().ends_with("</svg>"), "{}", path.display());
            if path.to_string_lossy().contains("tradeoff") {
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
}

#[test]
fn a_single_episode_run_is_drawn_with_markers() {
    let root = tempfile::tempdir().unwrap();
    // One DEFENDER run, one episode, one evaluation: single points are drawn as markers.
    RunSpec::new("sac", 0, A).outcomes(1, 1, 0).write(root.path());
    let set = load_runs(&[root.path()]).unwrap();
    let plots = draw_plots(&set.runs, root.path().join("p"), &PlotOptions::default()).unwrap();
    assert_eq!(plots.files.len(), 8);
    assert!(plots.notes.is_empty());
    let svg = std::fs::read_to_string(root.path().join("p/Hopper-v5_sac_eval.svg")).unwrap();
    assert!(svg.contains("<circle"), "{svg}");
}
