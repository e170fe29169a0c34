//! A small reader for the two numeric CSV files of a run directory (`metrics.csv`, `eval.csv`).
//!
//! The files are written by `defender train` with plain comma-separated fields and no quoting, so a
//! full CSV parser is not needed; what matters is an error that names the file, the line and the
//! column when something is off.

use std::path::Path;
use std::str::FromStr;

use crate::error::{ReportError, Result};

/// A CSV file split into a header and data rows, with column lookup by name.
pub(crate) struct CsvFile<'a> {
    path: &'a Path,
    /// Index in each row of each requested column, in the order requested.
    columns: Vec<usize>,
    names: &'static [&'static str],
    header: Vec<&'a str>,
    rows: Vec<(usize, Vec<&'a str>)>,
}

impl<'a> CsvFile<'a> {
    /// Splits `text` and finds the columns `names` in its header (extra columns are ignored, so
    /// that a later version of the contract can add some).
    pub(crate) fn parse(
        path: &'a Path,
        text: &'a str,
        expected: &'static str,
        names: &'static [&'static str],
    ) -> Result<Self> {
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
        let header = lines.next().map(|(_, l)| l).unwrap_or("");
        let header_fields: Vec<&str> = header.split(',').map(str::trim).collect();
        let mut columns = Vec::with_capacity(names.len());
        for &name in names {
            match header_fields.iter().position(|f| *f == name) {
                Some(i) => columns.push(i),
                None => {
                    return Err(ReportError::CsvHeader {
                        path: path.to_path_buf(),
                        expected,
                        got: header.to_string(),
                        missing: name,
                    });
                }
            }
        }
        let width = header_fields.len();
        let mut rows = Vec::new();
        for (line, text) in lines {
            if text.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = text.split(',').map(str::trim).collect();
            if fields.len() != width {
                return Err(ReportError::CsvRow {
                    path: path.to_path_buf(),
                    line,
                    message: format!("{} fields, the header has {width}", fields.len()),
                });
            }
            rows.push((line, fields));
        }
        Ok(Self { path, columns, names, header: header_fields, rows })
    }

    /// The index in each row of the column `name`, if the header has it: for columns a later
    /// version of the contract added, absent from older files.
    pub(crate) fn optional_column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|f| *f == name)
    }

    /// The data rows, as accessors.
    pub(crate) fn rows(&self) -> impl Iterator<Item = Row<'_, 'a>> {
        self.rows.iter().map(move |(line, fields)| Row { file: self, line: *line, fields })
    }
}

/// One data row of a [`CsvFile`].
pub(crate) struct Row<'f, 'a> {
    file: &'f CsvFile<'a>,
    line: usize,
    fields: &'f [&'a str],
}

impl Row<'_, '_> {
    /// The raw text of the `k`-th requested column.
    pub(crate) fn text(&self, k: usize) -> &str {
        self.fields[self.file.columns[k]]
    }

    /// The `k`-th requested column parsed as `T`.
    pub(crate) fn get<T: FromStr>(&self, k: usize) -> Result<T> {
        let text = self.text(k);
        text.parse().map_err(|_| self.error(format!("column {}: cannot read {text:?}", self.file.names[k])))
    }

    /// The `k`-th requested column as a finite floating-point number.
    pub(crate) fn finite(&self, k: usize) -> Result<f64> {
        let value: f64 = self.get(k)?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.error(format!("column {}: {value} is not a finite number", self.file.names[k])))
        }
    }

    /// The column at `index` ([`CsvFile::optional_column`]) as a finite number, `None` where
    /// the field is empty (a value the writer did not know).
    pub(crate) fn optional_finite(&self, index: usize, name: &str) -> Result<Option<f64>> {
        let text = self.fields[index];
        if text.is_empty() {
            return Ok(None);
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(self.error(format!("column {name}: {text:?} is not a finite number"))),
        }
    }

    /// An error about this row.
    pub(crate) fn error(&self, message: String) -> ReportError {
        ReportError::CsvRow { path: self.file.path.to_path_buf(), line: self.line, message }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAMES: &[&str] = &["a", "b"];

    #[test]
    fn finds_columns_by_name_and_ignores_extra_ones() {
        let path = Path::new("x.csv");
        let file = CsvFile::parse(path, "b,extra,a\r\n2,z,1\n\n4,y,3\n", "a,b", NAMES).unwrap();
        let rows: Vec<(u32, u32, usize)> =
            file.rows().map(|r| (r.get(0).unwrap(), r.get(1).unwrap(), r.line)).collect();
        assert_eq!(rows, vec![(1, 2, 2), (3, 4, 4)]);
    }

    #[test]
    fn errors_name_the_file_line_and_column() {
        let path = Path::new("x.csv");
        let err = CsvFile::parse(path, "a,c\n1,2\n", "a,b", NAMES).err().unwrap();
        assert!(err.to_string().contains("missing column \"b\""), "{err}");
        let err = CsvFile::parse(path, "a,b\n1,2,3\n", "a,b", NAMES).err().unwrap();
        assert_eq!(err.to_string(), "x.csv:2: 3 fields, the header has 2");
        let file = CsvFile::parse(path, "a,b\n1,2\n1,nan\n", "a,b", NAMES).unwrap();
        let errs: Vec<String> =
            file.rows().filter_map(|r| r.finite(1).err()).map(|e| e.to_string()).collect();
        assert_eq!(errs, vec!["x.csv:3: column b: NaN is not a finite number".to_string()]);
        let file = CsvFile::parse(path, "a,b\nx,2\n", "a,b", NAMES).unwrap();
        let err = file.rows().next().unwrap().get::<u32>(0).err().unwrap();
        assert_eq!(err.to_string(), "x.csv:2: column a: cannot read \"x\"");
    }
}
