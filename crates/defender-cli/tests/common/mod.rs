//! Helpers shared by the CLI's integration tests (each test file that needs them says `mod common;`).

use std::path::Path;

/// The lines of `dir/metrics.csv` without its `wall_seconds` column, the only one that depends on
/// the machine, so that two runs' files can be compared for bit-exactness. The column is found by
/// its name in the header: columns added later (like `cost`) must not shift it.
pub fn metrics_without_wall(dir: &Path) -> Vec<String> {
    let path = dir.join("metrics.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header = text.lines().next().unwrap_or_default();
    let wall = header
        .split(',')
        .position(|c| c == "wall_seconds")
        .unwrap_or_else(|| panic!("{}: no wall_seconds column in the header {header:?}", path.display()));
    text.lines()
        .map(|l| {
            l.split(',').enumerate().filter(|&(i, _)| i != wall).map(|(_, f)| f).collect::<Vec<_>>().join(",")
        })
        .collect()
}
