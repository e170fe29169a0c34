//! The report without the `defender` binary (which links MuJoCo): Markdown on stdout, plots into
//! a folder.
//!
//! ```sh
//! cargo run --release -p defender-report --example report -- runs/ plots/
//! ```

use defender_report::{Format, PlotOptions, Table, draw_plots, load_runs, render};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [runs, plots] = args.as_slice() else {
        return Err("usage: report RUNS_DIR PLOTS_DIR".into());
    };
    let set = load_runs(&[runs])?;
    for skipped in &set.skipped {
        eprintln!("warning: skipping {}: {}", skipped.dir.display(), skipped.reason);
    }
    print!("{}", render(&Table::from_runs(&set.runs), Format::Markdown));
    let drawn = draw_plots(&set.runs, plots, &PlotOptions::default())?;
    eprintln!("wrote {} plot files to {plots}", drawn.files.len());
    Ok(())
}
