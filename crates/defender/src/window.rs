//! Windows (SPEC section 3): which part of the trajectory and of a demonstration are aligned.

use std::fmt;
use std::str::FromStr;

use crate::error::{DefenderError, Result};

/// The part of the trajectory `x` (length n) and of a demonstration `y` (length m) that DTW aligns.
/// `v[-k:]` is the last `min(k, len(v))` elements.
///
/// | window    | trajectory | demonstration |
/// |-----------|------------|---------------|
/// | `Both`    | `x`        | `y`           |
/// | `Equal`   | `x`        | `y[-n:]`      |
/// | `TrajW5`, `TrajW10` | `x[-W:]` | `y`   |
/// | `DemoW5`, `DemoW10` | `x`      | `y[-W:]` |
/// | `BothW5`, `BothW10` | `x[-W:]` | `y[-W:]` |
///
/// The fixed order of [`Window::ALL`] (and of [`Window::index`]) is the order of this table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Window {
    /// The whole trajectory against the whole demonstration.
    Both,
    /// The whole trajectory against the demonstration's last n elements (n = trajectory length).
    Equal,
    /// The trajectory's last 5 elements against the whole demonstration.
    TrajW5,
    /// The trajectory's last 10 elements against the whole demonstration.
    TrajW10,
    /// The whole trajectory against the demonstration's last 5 elements.
    DemoW5,
    /// The whole trajectory against the demonstration's last 10 elements.
    DemoW10,
    /// The last 5 elements of both.
    BothW5,
    /// The last 10 elements of both.
    BothW10,
}

/// How much of one sequence a window keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Span {
    /// The whole sequence.
    All,
    /// The last `k` elements (all of them when the sequence is shorter).
    Last(usize),
    /// The demonstration's last n elements, n = the trajectory's length (`Equal`).
    MatchQuery,
}

impl Window {
    /// All 8 windows, in the fixed order of the SPEC table.
    pub const ALL: [Window; 8] = [
        Window::Both,
        Window::Equal,
        Window::TrajW5,
        Window::TrajW10,
        Window::DemoW5,
        Window::DemoW10,
        Window::BothW5,
        Window::BothW10,
    ];

    /// Position in [`Window::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The window's name as written in SPEC section 3.
    pub fn name(self) -> &'static str {
        match self {
            Window::Both => "Both",
            Window::Equal => "Equal",
            Window::TrajW5 => "TrajW5",
            Window::TrajW10 => "TrajW10",
            Window::DemoW5 => "DemoW5",
            Window::DemoW10 => "DemoW10",
            Window::BothW5 => "BothW5",
            Window::BothW10 => "BothW10",
        }
    }

    /// The part of the trajectory kept ([`Span::All`] or [`Span::Last`]).
    pub fn trajectory_span(self) -> Span {
        match self {
            Window::Both | Window::Equal | Window::DemoW5 | Window::DemoW10 => Span::All,
            Window::TrajW5 | Window::BothW5 => Span::Last(5),
            Window::TrajW10 | Window::BothW10 => Span::Last(10),
        }
    }

    /// The part of the demonstration kept.
    pub fn demonstration_span(self) -> Span {
        match self {
            Window::Both | Window::TrajW5 | Window::TrajW10 => Span::All,
            Window::Equal => Span::MatchQuery,
            Window::DemoW5 | Window::BothW5 => Span::Last(5),
            Window::DemoW10 | Window::BothW10 => Span::Last(10),
        }
    }

    /// The element ranges `(trajectory, demonstration)` this window keeps of a trajectory of
    /// length `n` and a demonstration of length `m` (SPEC section 3).
    pub fn ranges(self, n: usize, m: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let last = |k: usize, len: usize| len - k.min(len)..len;
        let x = match self.trajectory_span() {
            Span::Last(w) => last(w, n),
            Span::All | Span::MatchQuery => 0..n,
        };
        let y = match self.demonstration_span() {
            Span::All => 0..m,
            Span::Last(w) => last(w, m),
            Span::MatchQuery => last(n, m),
        };
        (x, y)
    }

    /// The streaming view of `defender-dtw` that computes this window.
    pub fn view(self) -> defender_dtw::View {
        use defender_dtw::{QueryWindow, RefWindow, View};
        let query = match self.trajectory_span() {
            Span::Last(w) => QueryWindow::Last(w),
            Span::All | Span::MatchQuery => QueryWindow::All,
        };
        let reference = match self.demonstration_span() {
            Span::All => RefWindow::All,
            Span::Last(w) => RefWindow::Last(w),
            Span::MatchQuery => RefWindow::MatchQuery,
        };
        View::new(query, reference)
    }

    fn valid_forms() -> String {
        Window::ALL.iter().map(|w| w.name()).collect::<Vec<_>>().join(", ")
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Window {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        Window::ALL.into_iter().find(|w| w.name() == s).ok_or_else(|| DefenderError::UnknownName {
            kind: "window",
            name: s.to_owned(),
            valid: Window::valid_forms(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_order() {
        let names: Vec<String> = Window::ALL.iter().map(|w| w.to_string()).collect();
        assert_eq!(names, ["Both", "Equal", "TrajW5", "TrajW10", "DemoW5", "DemoW10", "BothW5", "BothW10"]);
        for (i, w) in Window::ALL.into_iter().enumerate() {
            assert_eq!(w.index(), i);
            assert_eq!(w.name().parse::<Window>().unwrap(), w);
        }
        let err = "bothw5".parse::<Window>().unwrap_err().to_string();
        assert!(err.contains("'bothw5'") && err.contains("TrajW10"), "{err}");
    }

    #[test]
    fn ranges_follow_the_spec_table() {
        // n = 3 trajectory elements, m = 12 demonstration elements.
        assert_eq!(Window::Both.ranges(3, 12), (0..3, 0..12));
        assert_eq!(Window::Equal.ranges(3, 12), (0..3, 9..12));
        assert_eq!(Window::Equal.ranges(20, 12), (0..20, 0..12));
        assert_eq!(Window::TrajW5.ranges(3, 12), (0..3, 0..12));
        assert_eq!(Window::TrajW5.ranges(8, 12), (3..8, 0..12));
        assert_eq!(Window::TrajW10.ranges(30, 12), (20..30, 0..12));
        assert_eq!(Window::DemoW5.ranges(3, 12), (0..3, 7..12));
        assert_eq!(Window::DemoW10.ranges(3, 4), (0..3, 0..4));
        assert_eq!(Window::BothW5.ranges(8, 12), (3..8, 7..12));
        assert_eq!(Window::BothW10.ranges(8, 12), (0..8, 2..12));
    }
}
