//! The table as Markdown (for a terminal: `crate::markdown`), LaTeX (booktabs, laid out like the
//! paper's Tables 1 and 2: `crate::latex`) and CSV (one row per group, for scripts:
//! `crate::csv_out`).

use std::str::FromStr;

use crate::table::Table;

/// An output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Format {
    /// Markdown tables, one per trajectory mode and task, padded to read well in a terminal.
    #[default]
    Markdown,
    /// LaTeX tables (booktabs), one per trajectory mode, tasks side by side as in the paper.
    Latex,
    /// CSV: one row per task x algorithm x budget x strategy, mean and std columns.
    Csv,
}

impl FromStr for Format {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "md" | "markdown" => Ok(Format::Markdown),
            "latex" | "tex" => Ok(Format::Latex),
            "csv" => Ok(Format::Csv),
            _ => Err(format!("unknown format {s:?}: expected md, latex or csv")),
        }
    }
}

/// Renders `table` in `format`.
pub fn render(table: &Table, format: Format) -> String {
    match format {
        Format::Markdown => crate::markdown::markdown(table),
        Format::Latex => crate::latex::latex(table),
        Format::Csv => crate::csv_out::csv(table),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_parse() {
        assert_eq!("latex".parse::<Format>(), Ok(Format::Latex));
        assert_eq!("md".parse::<Format>(), Ok(Format::Markdown));
        assert!("html".parse::<Format>().is_err());
    }
}
