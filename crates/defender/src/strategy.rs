//! Strategies (SPEC section 3) and the trajectory mode (SPEC section 1).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::{DefenderError, Result};
use crate::method::Method;

/// A pair (method for the safe group, method for the unsafe group), written `SAFE/UNSAFE`,
/// e.g. `MeanDemoW5/MeanDemoW10`. There are 576.
///
/// The fixed order of [`Strategy::all`] is safe-major: index = `safe.index() * 24 + unsafe.index()`
/// (`MinBoth/MinBoth, MinBoth/MinEqual, ..., MeanBothW10/MeanBothW10`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Strategy {
    /// The method applied to the safe demonstrations (`Safe(tau)`).
    pub safe: Method,
    /// The method applied to the unsafe demonstrations (`Unsafe(tau)`).
    pub unsafe_: Method,
}

impl Strategy {
    /// Number of strategies (24 x 24).
    pub const COUNT: usize = Method::COUNT * Method::COUNT;

    /// A strategy from its two methods.
    pub const fn new(safe: Method, unsafe_: Method) -> Self {
        Self { safe, unsafe_ }
    }

    /// All 576 strategies in the fixed order.
    pub fn all() -> impl Iterator<Item = Strategy> {
        Method::all().flat_map(|s| Method::all().map(move |u| Strategy::new(s, u)))
    }

    /// Position in [`Strategy::all`].
    pub fn index(self) -> usize {
        self.safe.index() * Method::COUNT + self.unsafe_.index()
    }

    /// The strategy at `index` of [`Strategy::all`], if `index < 576`.
    pub fn from_index(index: usize) -> Option<Strategy> {
        if index >= Self::COUNT {
            return None;
        }
        Some(Strategy::new(
            Method::from_index(index / Method::COUNT)?,
            Method::from_index(index % Method::COUNT)?,
        ))
    }

    /// Parses a comma-separated list of strategies (`MinBoth/MinTrajW10,MeanBothW5/MeanBothW5`);
    /// spaces around names are ignored.
    ///
    /// # Errors
    /// A name that does not parse, or an empty list.
    pub fn parse_list(s: &str) -> Result<Vec<Strategy>> {
        let list = s.split(',').map(|p| p.trim().parse()).collect::<Result<Vec<Strategy>>>()?;
        if list.is_empty() {
            return Err(DefenderError::Config("empty list of strategies".into()));
        }
        Ok(list)
    }
}

impl fmt::Display for Strategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.safe, self.unsafe_)
    }
}

impl FromStr for Strategy {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        let unknown = || DefenderError::UnknownName {
            kind: "strategy",
            name: s.to_owned(),
            valid: format!(
                "SAFE/UNSAFE (e.g. MeanDemoW5/MeanDemoW10), each a method: {}",
                Method::valid_forms_without_example()
            ),
        };
        let (safe, unsafe_) = s.split_once('/').ok_or_else(unknown)?;
        match (safe.parse(), unsafe_.parse()) {
            (Ok(safe), Ok(unsafe_)) => Ok(Strategy::new(safe, unsafe_)),
            _ => Err(unknown()),
        }
    }
}

/// What a trajectory element is (SPEC section 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum Mode {
    /// `e_i = s_i` (the default); a demonstration of N transitions gives N + 1 elements.
    #[default]
    State,
    /// `e_i = concat(s_i, a_i)`; a demonstration of N transitions gives N elements.
    StateAction,
}

impl Mode {
    /// Both modes, state first.
    pub const ALL: [Mode; 2] = [Mode::State, Mode::StateAction];

    /// `state` or `state-action`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::State => "state",
            Mode::StateAction => "state-action",
        }
    }

    /// The dimension of one element for the given observation and action dimensions.
    pub fn element_dim(self, obs_dim: usize, act_dim: usize) -> usize {
        match self {
            Mode::State => obs_dim,
            Mode::StateAction => obs_dim + act_dim,
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = DefenderError;
    fn from_str(s: &str) -> Result<Self> {
        Mode::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| DefenderError::UnknownName {
            kind: "mode",
            name: s.to_owned(),
            valid: "state, state-action".into(),
        })
    }
}

/// Serialises names as their SPEC strings (for saved configurations).
macro_rules! serde_by_name {
    ($($t:ty),*) => {$(
        impl Serialize for $t {
            fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.collect_str(self)
            }
        }
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let s = String::deserialize(d)?;
                s.parse().map_err(serde::de::Error::custom)
            }
        }
    )*};
}
serde_by_name!(Strategy, Mode, Method, crate::window::Window, crate::method::Aggregation);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_576_strategies_parse_and_print() {
        let all: Vec<Strategy> = Strategy::all().collect();
        assert_eq!(all.len(), 576);
        assert_eq!(all[0].to_string(), "MinBoth/MinBoth");
        assert_eq!(all[575].to_string(), "MeanBothW10/MeanBothW10");
        for (i, s) in all.iter().enumerate() {
            assert_eq!(s.index(), i);
            assert_eq!(Strategy::from_index(i), Some(*s));
            assert_eq!(s.to_string().parse::<Strategy>().unwrap(), *s);
        }
        assert_eq!(Strategy::from_index(576), None);
    }

    #[test]
    fn the_papers_strategies_parse() {
        let s: Strategy = "MeanDemoW5/MeanDemoW10".parse().unwrap();
        assert_eq!(s.safe.to_string(), "MeanDemoW5");
        assert_eq!(s.unsafe_.to_string(), "MeanDemoW10");
        let s: Strategy = "MinBoth/MinTrajW10".parse().unwrap();
        assert_eq!(s.to_string(), "MinBoth/MinTrajW10");
        let list = Strategy::parse_list("MinBoth/MinTrajW10, MeanBothW5/MeanBothW5").unwrap();
        assert_eq!(list.len(), 2);
    }

    #[test]
    fn unknown_strategies_are_errors_listing_the_valid_forms() {
        for bad in [
            "",
            "MinBoth",
            "MinBoth/",
            "/MinBoth",
            "MinBoth/MinBoth/MinBoth",
            "minboth/minboth",
            "MinBoth-MinBoth",
        ] {
            let err = bad.parse::<Strategy>().unwrap_err().to_string();
            assert!(err.contains("unknown strategy") && err.contains("SAFE/UNSAFE"), "{err}");
        }
        assert!(Strategy::parse_list("MinBoth/MinBoth,Nope").is_err());
    }

    #[test]
    fn modes_parse_and_print() {
        assert_eq!(Mode::default(), Mode::State);
        assert_eq!("state".parse::<Mode>().unwrap(), Mode::State);
        assert_eq!("state-action".parse::<Mode>().unwrap(), Mode::StateAction);
        assert_eq!(Mode::StateAction.to_string(), "state-action");
        assert!("State".parse::<Mode>().unwrap_err().to_string().contains("state-action"));
        assert_eq!(Mode::StateAction.element_dim(11, 3), 14);
        assert_eq!(Mode::State.element_dim(11, 3), 11);
    }

    #[test]
    fn names_serialise_as_strings() {
        let s: Strategy = "MinBoth/MinTrajW10".parse().unwrap();
        let json = serde_json::to_string(&(s, Mode::StateAction)).unwrap();
        assert_eq!(json, r#"["MinBoth/MinTrajW10","state-action"]"#);
        let back: (Strategy, Mode) = serde_json::from_str(&json).unwrap();
        assert_eq!(back, (s, Mode::StateAction));
        assert!(serde_json::from_str::<Strategy>(r#""MinBoth""#).is_err());
    }
}
