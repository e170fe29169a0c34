//! Figures as rows: what was measured, its value and unit, the target it is held to, and notes.

use crate::text_table::{Column, TextTable};

/// The bound a figure is held to.
#[derive(Debug, Clone, Copy)]
pub(super) enum Target {
    AtLeast(f64),
    AtMost(f64),
}

impl Target {
    pub(super) fn met(self, value: f64) -> bool {
        match self {
            Target::AtLeast(t) => value >= t,
            Target::AtMost(t) => value <= t,
        }
    }
    pub(super) fn text(self) -> String {
        match self {
            Target::AtLeast(t) => format!(">= {t}"),
            Target::AtMost(t) => format!("<= {t}"),
        }
    }
}

/// One line of the table.
#[derive(Debug)]
pub(super) struct Row {
    pub(super) figure: &'static str,
    pub(super) what: String,
    value: f64,
    unit: &'static str,
    pub(super) target: Option<Target>,
    notes: String,
}

impl Row {
    pub(super) fn new(figure: &'static str, what: impl Into<String>, value: f64, unit: &'static str) -> Self {
        Self { figure, what: what.into(), value, unit, target: None, notes: String::new() }
    }
    pub(super) fn target(mut self, target: Target) -> Self {
        self.target = Some(target);
        self
    }
    pub(super) fn notes(mut self, notes: impl Into<String>) -> Self {
        self.notes = notes.into();
        self
    }
    pub(super) fn met(&self) -> Option<bool> {
        self.target.map(|t| t.met(self.value))
    }
    pub(super) fn short(&self) -> String {
        format!("{} {}", self.figure, self.what)
    }
}

/// A number with a precision that suits its size.
pub(super) fn number(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a >= 1000.0 {
        format!("{v:.0}")
    } else if a >= 100.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// The table of figures, with a rule under its header.
pub(super) fn table(rows: &[Row]) -> String {
    let mut table = TextTable::new(vec![
        Column::left("figure"),
        Column::left("what"),
        Column::right("value"),
        Column::left("unit"),
        Column::left("target"),
        Column::left("status"),
        Column::left("notes"),
    ])
    .with_rule();
    for r in rows {
        table.row([
            r.figure.to_string(),
            r.what.clone(),
            number(r.value),
            r.unit.to_string(),
            r.target.map_or("-".into(), Target::text),
            match r.met() {
                None => "-".into(),
                Some(true) => "met".into(),
                Some(false) => "NOT MET".into(),
            },
            r.notes.clone(),
        ]);
    }
    table.render()
}
