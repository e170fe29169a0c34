//! The options of the alignment cost and of the decision built on it (`[defender.cost]`).
//!
//! The defaults are SPEC sections 1-4: exact DTW with the Euclidean point distance over the whole
//! trajectory, a demonstration's sequence with its final observation (state mode), ties filter.
//! The other values exist to run the paper's experiments as its authors' code ran them
//! (docs/SPEC.md, "The authors' profile"): FastDTW with the L1 point distance over the last 20
//! trajectory elements, one element per transition, ties executed.

use serde::{Deserialize, Serialize};

use crate::error::{DefenderError, Result};

/// Names an enum's values for configurations, parsing and errors.
macro_rules! named_enum {
    ($(#[$meta:meta])* $name:ident, $kind:literal, $valid:literal, { $($(#[$vmeta:meta])* $variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
        pub enum $name {
            $($(#[$vmeta])* #[serde(rename = $text)] $variant),+
        }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The name in configurations and CSV files.
            pub fn name(self) -> &'static str {
                match self { $($name::$variant => $text),+ }
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $name {
            type Err = DefenderError;
            fn from_str(s: &str) -> Result<Self> {
                $name::ALL.iter().copied().find(|v| v.name() == s).ok_or_else(|| DefenderError::UnknownName {
                    kind: $kind,
                    name: s.to_string(),
                    valid: $valid.to_string(),
                })
            }
        }
    };
}

named_enum!(
    /// Feature scaling applied to demonstrations and trajectories alike before DTW.
    Scaling, "scaling", "none (plain DTW), zscore", {
        /// No scaling (SPEC section 2's default).
        #[default]
        None = "none",
        /// Per feature, subtract the mean and divide by the standard deviation, both fitted on
        /// every element of every demonstration (both groups). A feature with standard deviation
        /// below 1e-6 is only centred.
        Zscore = "zscore",
    }
);

named_enum!(
    /// Which DTW computes a windowed cost.
    DtwKind, "dtw", "exact, fastdtw", {
        /// Exact DTW (SPEC section 2).
        #[default]
        Exact = "exact",
        /// FastDTW (Salvador and Chan 2007) exactly as the PyPI `fastdtw` package computes it,
        /// with the radius of [`CostOptions::radius`]: an approximation from above.
        Fastdtw = "fastdtw",
    }
);

named_enum!(
    /// The distance between two trajectory elements.
    Metric, "metric", "l2 (Euclidean), l1 (Manhattan)", {
        /// `||x - y||_2` (SPEC section 2).
        #[default]
        L2 = "l2",
        /// `||x - y||_1`: the `fastdtw` package's default for vectors.
        L1 = "l1",
    }
);

named_enum!(
    /// How a demonstration becomes a sequence in state mode (SPEC section 1).
    Elements, "elements", "spec (state mode: the final observation included), per-transition", {
        /// `[o_0 .. o_N]`: N + 1 elements, the final observation included.
        #[default]
        Spec = "spec",
        /// One element per transition, `[o_0 .. o_{N-1}]` (the authors' code); state-action mode
        /// is the same under both rules.
        PerTransition = "per-transition",
    }
);

named_enum!(
    /// What an equal safe and unsafe cost decides (SPEC section 4).
    Ties, "ties", "filter, execute", {
        /// `Safe >= Unsafe` filters (SPEC section 4).
        #[default]
        Filter = "filter",
        /// Only `Safe > Unsafe` filters (the authors' code).
        Execute = "execute",
    }
);

/// The default FastDTW radius (the `fastdtw` package's).
pub const DEFAULT_RADIUS: usize = 1;

/// Options of the alignment cost and of the decision; the defaults are SPEC sections 1-4.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostOptions {
    /// Feature scaling (default none).
    #[serde(default)]
    pub scaling: Scaling,
    /// Exact DTW or FastDTW.
    #[serde(default)]
    pub dtw: DtwKind,
    /// FastDTW's radius (unused by exact DTW).
    #[serde(default = "default_radius")]
    pub radius: usize,
    /// The point distance.
    #[serde(default)]
    pub metric: Metric,
    /// Align only the last N trajectory elements (before any window); `None`: all of them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory_cap: Option<usize>,
    /// How a demonstration becomes a sequence.
    #[serde(default)]
    pub elements: Elements,
    /// What a tie decides.
    #[serde(default)]
    pub ties: Ties,
}

fn default_radius() -> usize {
    DEFAULT_RADIUS
}

impl Default for CostOptions {
    fn default() -> Self {
        Self::with_scaling(Scaling::None)
    }
}

/// The largest FastDTW radius accepted: beyond it FastDTW is exact DTW at a higher cost.
pub const MAX_RADIUS: usize = 1 << 16;

impl CostOptions {
    /// SPEC's cost with the given scaling.
    pub const fn with_scaling(scaling: Scaling) -> Self {
        Self {
            scaling,
            dtw: DtwKind::Exact,
            radius: DEFAULT_RADIUS,
            metric: Metric::L2,
            trajectory_cap: None,
            elements: Elements::Spec,
            ties: Ties::Filter,
        }
    }

    /// The authors' cost (docs/SPEC.md, "The authors' profile"): FastDTW, radius 1, L1, the
    /// last 20 elements, one element per transition, ties executed; no scaling.
    pub fn authors() -> Self {
        Self {
            scaling: Scaling::None,
            dtw: DtwKind::Fastdtw,
            radius: DEFAULT_RADIUS,
            metric: Metric::L1,
            trajectory_cap: Some(20),
            elements: Elements::PerTransition,
            ties: Ties::Execute,
        }
    }

    /// Whether the streaming exact kernels compute this cost (exact Euclidean DTW over the whole
    /// trajectory); otherwise every step recomputes each window from the capped trajectory.
    pub fn is_incremental(&self) -> bool {
        self.dtw == DtwKind::Exact && self.metric == Metric::L2 && self.trajectory_cap.is_none()
    }

    /// Checks the values a configuration file can get wrong.
    ///
    /// # Errors
    /// [`DefenderError::Config`] naming the setting: `trajectory_cap = 0`, a radius above
    /// [`MAX_RADIUS`].
    pub fn validate(&self) -> Result<()> {
        if self.trajectory_cap == Some(0) {
            return Err(DefenderError::Config(
                "[defender.cost] trajectory_cap = 0: it must be at least 1 (or left out to align the whole \
                 trajectory)"
                    .into(),
            ));
        }
        if self.radius > MAX_RADIUS {
            return Err(DefenderError::Config(format!(
                "[defender.cost] radius = {}: it must be at most {MAX_RADIUS}",
                self.radius
            )));
        }
        Ok(())
    }

    /// A short label for tables and CSV files: the scaling alone for SPEC's cost (as before the
    /// other options existed), else every option that differs from SPEC's.
    pub fn label(&self) -> String {
        let spec = Self::with_scaling(self.scaling);
        if *self == spec {
            return self.scaling.name().to_string();
        }
        let mut parts = vec![self.scaling.name().to_string()];
        if self.dtw != spec.dtw {
            parts.push(format!("{}(r={})", self.dtw, self.radius));
        }
        if self.metric != spec.metric {
            parts.push(self.metric.name().to_string());
        }
        if let Some(cap) = self.trajectory_cap {
            parts.push(format!("cap{cap}"));
        }
        if self.elements != spec.elements {
            parts.push(self.elements.name().to_string());
        }
        if self.ties != spec.ties {
            parts.push(format!("ties-{}", self.ties));
        }
        parts.join("+")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_spec_and_partial_tables_fill_in() {
        let c: CostOptions = toml::from_str("scaling = \"zscore\"").unwrap();
        assert_eq!(c, CostOptions::with_scaling(Scaling::Zscore));
        assert!(c.is_incremental());
        let a: CostOptions = toml::from_str(&toml::to_string(&CostOptions::authors()).unwrap()).unwrap();
        assert_eq!(a, CostOptions::authors());
        assert!(!a.is_incremental());
        assert_eq!(a.label(), "none+fastdtw(r=1)+l1+cap20+per-transition+ties-execute");
        assert_eq!(CostOptions::default().label(), "none");
        let err = toml::from_str::<CostOptions>("metric = \"l3\"").unwrap_err().to_string();
        assert!(err.contains("l3"), "{err}");
    }

    #[test]
    fn a_zero_cap_is_refused_by_name() {
        let c = CostOptions { trajectory_cap: Some(0), ..CostOptions::default() };
        assert!(c.validate().unwrap_err().to_string().contains("trajectory_cap"));
        assert!(CostOptions::authors().validate().is_ok());
        assert_eq!("execute".parse::<Ties>().unwrap(), Ties::Execute);
        assert!("both".parse::<Ties>().unwrap_err().to_string().contains("filter, execute"));
    }
}
