//! The command line's one text-table printer (`bench`, `select`, `ablate`): columns padded to
//! their widest cell (or a minimum width), two spaces apart, no trailing blanks, optionally a rule
//! of dashes under the header. Machine-readable output is CSV, written by the libraries.

/// How a column's cells sit in its width.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    Left,
    Right,
}

/// A column: its header, alignment and minimum width.
#[derive(Debug, Clone)]
pub struct Column {
    header: &'static str,
    align: Align,
    min_width: usize,
}

impl Column {
    pub fn left(header: &'static str) -> Self {
        Self { header, align: Align::Left, min_width: 0 }
    }

    pub fn right(header: &'static str) -> Self {
        Self { header, align: Align::Right, min_width: 0 }
    }

    /// Pads the column to at least `width` characters, so that a short table keeps its layout.
    pub fn min_width(mut self, width: usize) -> Self {
        self.min_width = width;
        self
    }
}

/// A table being filled row by row, rendered at the end (widths depend on every cell).
#[derive(Debug, Clone)]
pub struct TextTable {
    columns: Vec<Column>,
    rows: Vec<Vec<String>>,
    rule: bool,
}

impl TextTable {
    pub fn new(columns: Vec<Column>) -> Self {
        Self { columns, rows: Vec::new(), rule: false }
    }

    /// A rule of dashes under the header.
    pub fn with_rule(mut self) -> Self {
        self.rule = true;
        self
    }

    /// Adds a row; missing cells are blank and extra ones are dropped, so a row can never shift
    /// the columns.
    pub fn row(&mut self, cells: impl IntoIterator<Item = String>) {
        let mut cells: Vec<String> = cells.into_iter().take(self.columns.len()).collect();
        cells.resize(self.columns.len(), String::new());
        self.rows.push(cells);
    }

    /// The table, one line per row, each ending in a newline.
    pub fn render(&self) -> String {
        let last = self.columns.len().saturating_sub(1);
        let widths: Vec<usize> = self
            .columns
            .iter()
            .enumerate()
            .map(|(c, col)| {
                // A left-aligned last column is not padded, so its width is its header's.
                let cells = if c == last && col.align == Align::Left { 0 } else { self.widest(c) };
                cells.max(col.header.chars().count()).max(col.min_width)
            })
            .collect();
        let mut out = String::new();
        let headers: Vec<String> = self.columns.iter().map(|c| c.header.to_string()).collect();
        self.line(&mut out, &headers, &widths);
        if self.rule {
            let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
            self.line(&mut out, &rule, &widths);
        }
        for row in &self.rows {
            self.line(&mut out, row, &widths);
        }
        out
    }

    fn widest(&self, column: usize) -> usize {
        self.rows.iter().map(|r| r[column].chars().count()).max().unwrap_or(0)
    }

    fn line(&self, out: &mut String, cells: &[String], widths: &[usize]) {
        let mut text = String::new();
        for (c, (cell, col)) in cells.iter().zip(&self.columns).enumerate() {
            if c > 0 {
                text.push_str("  ");
            }
            let pad = widths[c].saturating_sub(cell.chars().count());
            match col.align {
                Align::Left => {
                    text.push_str(cell);
                    text.push_str(&" ".repeat(pad));
                }
                Align::Right => {
                    text.push_str(&" ".repeat(pad));
                    text.push_str(cell);
                }
            }
        }
        out.push_str(text.trim_end());
        out.push('\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_padded_aligned_and_trimmed() {
        let mut t = TextTable::new(vec![Column::right("rank"), Column::left("name"), Column::right("score")]);
        t.row(["1".to_string(), "a".into(), "0.5".into()]);
        t.row(["10".to_string(), "longer".into(), "12.25".into()]);
        assert_eq!(t.render(), "rank  name    score\n   1  a         0.5\n  10  longer  12.25\n");
    }

    #[test]
    fn rule_and_unpadded_last_column() {
        let mut t = TextTable::new(vec![Column::left("what"), Column::left("notes")]).with_rule();
        t.row(["x".to_string(), "a long note".into()]);
        t.row(["yyyyyy".to_string(), String::new()]);
        assert_eq!(t.render(), "what    notes\n------  -----\nx       a long note\nyyyyyy\n");
    }

    #[test]
    fn minimum_width_and_short_rows() {
        let mut t = TextTable::new(vec![Column::left("s").min_width(4), Column::right("v").min_width(3)]);
        t.row(["a".to_string()]);
        t.row(["b".to_string(), "1".into(), "ignored".into()]);
        assert_eq!(t.render(), "s       v\na\nb       1\n");
    }
}
