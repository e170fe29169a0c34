//! The ablation's CSV (SPEC section 9): rows of [`AblationRow`] written and read back exactly,
//! with the score's name in a last column when it is not SPEC's. Its own file so that the scores
//! (crate::score) need not know the scorings (crate::scoring) that compute them.

use std::io::Write;
use std::path::Path;

use crate::atomic::{io_at, write_atomic};
use crate::error::{DefenderError, Result};
use crate::score::AblationRow;
use crate::scoring::Scoring;
use crate::strategy::Strategy;

/// The CSV header of SPEC section 9.
pub const CSV_HEADER: &str = "rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score";

/// Writes rows as the CSV of SPEC section 9, atomically. Numbers are written in Rust's shortest
/// round-trip form, so [`read_csv`] gives them back exactly.
///
/// # Errors
/// An I/O error.
pub fn write_csv(path: impl AsRef<Path>, rows: &[AblationRow]) -> Result<()> {
    write_csv_scored(path, rows, Scoring::Spec)
}

/// [`write_csv`] for rows `scoring` computed: SPEC's are written as [`write_csv`] writes them;
/// any other gets a last column, `scoring`, naming it on every row (SPEC section 9 allows
/// columns after its own), so that a file says what its scores mean.
///
/// # Errors
/// An I/O error.
pub fn write_csv_scored(path: impl AsRef<Path>, rows: &[AblationRow], scoring: Scoring) -> Result<()> {
    let path = path.as_ref();
    let extra = match scoring {
        Scoring::Spec => String::new(),
        other => format!(",{}", other.name()),
    };
    write_atomic(path, |w| {
        let header_extra = if extra.is_empty() { "" } else { ",scoring" };
        writeln!(w, "{CSV_HEADER}{header_extra}").map_err(io_at(path))?;
        for r in rows {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{}{extra}",
                r.rank,
                r.strategy,
                r.strategy.safe,
                r.strategy.unsafe_,
                r.mode,
                r.mean_ratio,
                r.safe_rate,
                r.score
            )
            .map_err(io_at(path))?;
        }
        Ok(())
    })
}

/// The scoring a CSV of [`write_csv_scored`] names in its `scoring` column (`spec` when it has
/// none, as [`write_csv`] writes SPEC's).
///
/// # Errors
/// An I/O error, or a file without the header of SPEC section 9.
pub fn csv_scoring(path: impl AsRef<Path>) -> Result<String> {
    let path = path.as_ref();
    let text = defender_io::read_input_to_string(path).map_err(io_at(path))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if !header.starts_with(CSV_HEADER) {
        return Err(DefenderError::Format {
            path: path.to_owned(),
            what: format!("line 1: expected the header `{CSV_HEADER}`, got {header:?}"),
        });
    }
    let Some(column) = header.split(',').position(|c| c == "scoring") else { return Ok("spec".into()) };
    Ok(lines.next().and_then(|l| l.split(',').nth(column)).unwrap_or("spec").to_string())
}

/// Reads a CSV written by [`write_csv`] (extra trailing columns are ignored).
///
/// # Errors
/// An I/O error, a wrong header, or a malformed row (naming the file and line).
pub fn read_csv(path: impl AsRef<Path>) -> Result<Vec<AblationRow>> {
    let path = path.as_ref();
    let text = defender_io::read_input_to_string(path).map_err(io_at(path))?;
    let mut lines = text.lines();
    let format = |line: usize, what: String| DefenderError::Format {
        path: path.to_owned(),
        what: format!("line {line}: {what}"),
    };
    match lines.next() {
        Some(h) if h.starts_with(CSV_HEADER) => {}
        other => return Err(format(1, format!("expected the header `{CSV_HEADER}`, got {other:?}"))),
    }
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let n = i + 2;
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 8 {
            return Err(format(n, format!("expected 8 columns, got {}", f.len())));
        }
        let num =
            |k: usize| f[k].parse::<f64>().map_err(|e| format(n, format!("column {k} `{}`: {e}", f[k])));
        let strategy: Strategy = f[1].parse().map_err(|e| format(n, format!("{e}")))?;
        if f[2] != strategy.safe.to_string() || f[3] != strategy.unsafe_.to_string() {
            return Err(format(
                n,
                format!("safe_method/unsafe_method `{},{}` do not match strategy `{strategy}`", f[2], f[3]),
            ));
        }
        rows.push(AblationRow {
            rank: f[0].parse().map_err(|e| format(n, format!("rank `{}`: {e}", f[0])))?,
            strategy,
            mode: f[4].parse().map_err(|e| format(n, format!("{e}")))?,
            mean_ratio: num(5)?,
            safe_rate: num(6)?,
            score: num(7)?,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::score::rank;
    use crate::score::tests::row;

    #[test]
    fn csv_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ablation.csv");
        let rows = rank(vec![row("MeanDemoW5/MeanDemoW10", 0.1 + 0.2), row("MinBoth/MinTrajW10", 1.0 / 3.0)]);
        write_csv(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("rank,strategy,safe_method,unsafe_method,mode,mean_ratio,safe_rate,score\n")
        );
        assert!(text.contains("\n1,MinBoth/MinTrajW10,MinBoth,MinTrajW10,state,"), "{text}");
        assert_eq!(read_csv(&path).unwrap(), rows);
        assert_eq!(csv_scoring(&path).unwrap(), "spec");
        let authors = dir.path().join("authors.csv");
        write_csv_scored(&authors, &rows, Scoring::Authors { horizon: 1000 }).unwrap();
        let text = std::fs::read_to_string(&authors).unwrap();
        assert!(text.starts_with(&format!("{CSV_HEADER},scoring\n")), "{text}");
        assert!(text.lines().skip(1).all(|l| l.ends_with(",authors")), "{text}");
        assert_eq!(read_csv(&authors).unwrap(), rows);
        assert_eq!(csv_scoring(&authors).unwrap(), "authors");
        std::fs::write(&path, "bad header\n").unwrap();
        assert!(read_csv(&path).unwrap_err().to_string().contains("line 1"));
    }
}
