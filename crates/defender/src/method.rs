//! Aggregations and methods (SPEC section 3): how one group's windowed costs become one number.

use std::fmt;
use std::str::FromStr;

use crate::error::{DefenderError, Result};
use crate::window::Window;

/// Reduces the windowed costs of one group's demonstrations to one number.
/// The fixed order of [`Aggregation::ALL`] is `Min`, `Max`, `Mean`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Aggregation {
    /// The smallest cost (the closest demonstration).
    Min,
    /// The largest cost.
    Max,
    /// The arithmetic mean of the costs.
    Mean,
}

impl Aggregation {
    /// All 3 aggregations, in the fixed order.
    pub const ALL: [Aggregation; 3] = [Aggregation::Min, Aggregation::Max, Aggregation::Mean];

    /// Position in [`Aggregation::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The name as written in SPEC section 3.
    pub fn name(self) -> &'static str {
        match self {
            Aggregation::Min => "Min",
            Aggregation::Max => "Max",
            Aggregation::Mean => "Mean",
        }
    }

    /// Applies the aggregation to one group's costs, accumulating in f64 (in the order given, so
    /// that the online filter, the ablation and the direct implementation agree bit for bit).
    /// An empty slice gives NaN (groups are never empty: loading refuses that).
    pub fn apply(self, costs: &[f32]) -> f64 {
        if costs.is_empty() {
            return f64::NAN;
        }
        match self {
            Aggregation::Min => costs.iter().fold(f64::INFINITY, |a, &c| a.min(f64::from(c))),
            Aggregation::Max => costs.iter().fold(f64::NEG_INFINITY, |a, &c| a.max(f64::from(c))),
            Aggregation::Mean => costs.iter().map(|&c| f64::from(c)).sum::<f64>() / costs.len() as f64,
        }
    }

    /// Min, max and mean of `costs` in one pass, indexed as [`Aggregation::ALL`]; each equals
    /// [`Aggregation::apply`] exactly.
    pub fn apply_all(costs: &[f32]) -> [f64; 3] {
        if costs.is_empty() {
            return [f64::NAN; 3];
        }
        let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for &c in costs {
            let c = f64::from(c);
            lo = lo.min(c);
            hi = hi.max(c);
            sum += c;
        }
        [lo, hi, sum / costs.len() as f64]
    }

    /// [`Aggregation::apply_all`] of `costs` without the element at `skip` (when given): equal
    /// bit for bit to `apply_all` of the slice with that element removed, since the remaining
    /// costs are visited in the same order. Leave-one-out uses it (crate::selection).
    pub(crate) fn apply_all_except(costs: &[f32], skip: Option<usize>) -> [f64; 3] {
        let Some(skip) = skip.filter(|&i| i < costs.len()) else {
            return Self::apply_all(costs);
        };
        if costs.len() == 1 {
            return [f64::NAN; 3];
        }
        let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for (i, &c) in costs.iter().enumerate() {
            if i != skip {
                let c = f64::from(c);
                lo = lo.min(c);
                hi = hi.max(c);
                sum += c;
            }
        }
        [lo, hi, sum / (costs.len() - 1) as f64]
    }
}

impl fmt::Display for Aggregation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Aggregation {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        Aggregation::ALL.into_iter().find(|a| a.name() == s).ok_or_else(|| DefenderError::UnknownName {
            kind: "aggregation",
            name: s.to_owned(),
            valid: "Min, Max, Mean".into(),
        })
    }
}

/// Aggregation + window, written as one word (`MinBoth`, `MeanDemoW5`, `MaxEqual`): one way of
/// comparing the trajectory with a group of demonstrations. There are 24.
///
/// The fixed order of [`Method::all`] is aggregation-major: `MinBoth, MinEqual, MinTrajW5, ...,
/// MinBothW10, MaxBoth, ..., MeanBothW10` (aggregations as [`Aggregation::ALL`], windows as
/// [`Window::ALL`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Method {
    /// How the group's costs are reduced.
    pub aggregation: Aggregation,
    /// Which parts of the sequences are aligned.
    pub window: Window,
}

impl Method {
    /// Number of methods (3 x 8).
    pub const COUNT: usize = 24;

    /// A method from its parts.
    pub const fn new(aggregation: Aggregation, window: Window) -> Self {
        Self { aggregation, window }
    }

    /// All 24 methods in the fixed order.
    pub fn all() -> impl Iterator<Item = Method> {
        Aggregation::ALL.into_iter().flat_map(|a| Window::ALL.into_iter().map(move |w| Method::new(a, w)))
    }

    /// Position in [`Method::all`]: `aggregation.index() * 8 + window.index()`.
    pub fn index(self) -> usize {
        self.aggregation.index() * Window::ALL.len() + self.window.index()
    }

    /// The method at `index` of [`Method::all`], if `index < 24`.
    pub fn from_index(index: usize) -> Option<Method> {
        let n = Window::ALL.len();
        Some(Method::new(*Aggregation::ALL.get(index / n)?, *Window::ALL.get(index % n)?))
    }

    pub(crate) fn valid_forms() -> String {
        format!("{} (e.g. MeanDemoW5)", Self::valid_forms_without_example())
    }

    /// [`Method::valid_forms`] without its example, for a message that gives one of its own.
    pub(crate) fn valid_forms_without_example() -> String {
        format!(
            "AGGREGATION followed by WINDOW, AGGREGATION one of Min, Max, Mean and WINDOW one of {}",
            Window::ALL.iter().map(|w| w.name()).collect::<Vec<_>>().join(", ")
        )
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.aggregation, self.window)
    }
}

impl FromStr for Method {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        Aggregation::ALL
            .into_iter()
            .find_map(|a| {
                let rest = s.strip_prefix(a.name())?;
                Window::ALL.into_iter().find(|w| w.name() == rest).map(|w| Method::new(a, w))
            })
            .ok_or_else(|| DefenderError::UnknownName {
                kind: "method",
                name: s.to_owned(),
                valid: Method::valid_forms(),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_24_methods_parse_and_print() {
        let all: Vec<Method> = Method::all().collect();
        assert_eq!(all.len(), Method::COUNT);
        assert_eq!(all[0].to_string(), "MinBoth");
        assert_eq!(all[1].to_string(), "MinEqual");
        assert_eq!(all[23].to_string(), "MeanBothW10");
        for (i, m) in all.iter().enumerate() {
            assert_eq!(m.index(), i);
            assert_eq!(Method::from_index(i), Some(*m));
            assert_eq!(m.to_string().parse::<Method>().unwrap(), *m);
        }
        assert_eq!(Method::from_index(24), None);
        let names: std::collections::HashSet<String> = all.iter().map(|m| m.to_string()).collect();
        assert_eq!(names.len(), 24);
    }

    #[test]
    fn unknown_methods_are_errors_listing_the_valid_forms() {
        for bad in
            ["", "Min", "Both", "meanDemoW5", "MeanDemoW7", "MedianBoth", "MeanDemoW5 ", "MinBoth/MinBoth"]
        {
            let err = bad.parse::<Method>().unwrap_err().to_string();
            assert!(
                err.contains("unknown method") && err.contains("DemoW10") && err.contains("Mean"),
                "{err}"
            );
        }
    }

    #[test]
    fn aggregations_reduce_costs() {
        let c = [3.0f32, 1.0, 2.0, 6.0];
        assert_eq!(Aggregation::Min.apply(&c), 1.0);
        assert_eq!(Aggregation::Max.apply(&c), 6.0);
        assert_eq!(Aggregation::Mean.apply(&c), 3.0);
        assert_eq!(Aggregation::apply_all(&c), [1.0, 6.0, 3.0]);
        assert_eq!(Aggregation::apply_all_except(&c, None), [1.0, 6.0, 3.0]);
        assert_eq!(Aggregation::apply_all_except(&c, Some(1)), Aggregation::apply_all(&[3.0, 2.0, 6.0]));
        assert!(Aggregation::apply_all_except(&[1.0], Some(0))[2].is_nan());
        assert!(Aggregation::Mean.apply(&[]).is_nan());
        assert_eq!("Max".parse::<Aggregation>().unwrap(), Aggregation::Max);
        assert!("max".parse::<Aggregation>().is_err());
    }
}
