//! Choosing an algorithm at run time (`algo = "sac"` and an `[algo_config]` table).

use serde::{Deserialize, Serialize};

use crate::agent::Agent;
use crate::config::{SacConfig, Td3Config};
use crate::error::RlError;
use crate::sac::Sac;
use crate::td3::Td3;

/// An algorithm's name, as in the run directory's `algo` key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Algo {
    /// Soft Actor-Critic.
    Sac,
    /// Twin Delayed DDPG.
    Td3,
}

impl Algo {
    /// `"sac"` or `"td3"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Sac => "sac",
            Self::Td3 => "td3",
        }
    }
}

impl std::fmt::Display for Algo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for Algo {
    type Err = RlError;
    fn from_str(s: &str) -> Result<Self, RlError> {
        match s {
            "sac" => Ok(Self::Sac),
            "td3" => Ok(Self::Td3),
            _ => Err(RlError::Config { field: "algo", value: s.into(), expected: "\"sac\" or \"td3\"" }),
        }
    }
}

/// The hyperparameters of one algorithm.
#[derive(Debug, Clone, PartialEq)]
pub enum AlgoConfig {
    /// SAC's.
    Sac(SacConfig),
    /// TD3's.
    Td3(Td3Config),
}

impl AlgoConfig {
    /// The defaults of `algo`.
    pub fn default_for(algo: Algo) -> Self {
        match algo {
            Algo::Sac => Self::Sac(SacConfig::default()),
            Algo::Td3 => Self::Td3(Td3Config::default()),
        }
    }

    /// Reads the hyperparameters of `algo` from any serde source, e.g. the `[algo_config]`
    /// table of a TOML file as a `toml::Value` (missing keys take their defaults; unknown keys are
    /// refused, naming the key).
    ///
    /// # Errors
    /// The deserializer's error.
    pub fn deserialize_for<'de, D: serde::Deserializer<'de>>(algo: Algo, de: D) -> Result<Self, D::Error> {
        Ok(match algo {
            Algo::Sac => Self::Sac(SacConfig::deserialize(de)?),
            Algo::Td3 => Self::Td3(Td3Config::deserialize(de)?),
        })
    }

    /// Which algorithm.
    pub fn algo(&self) -> Algo {
        match self {
            Self::Sac(_) => Algo::Sac,
            Self::Td3(_) => Algo::Td3,
        }
    }

    /// Whether the agent stores the run's demonstrations in its replay buffer before training.
    pub fn demos_in_replay(&self) -> bool {
        match self {
            Self::Sac(c) => c.demos_in_replay,
            Self::Td3(c) => c.demos_in_replay,
        }
    }

    /// Builds the agent for observations of `obs_dim` and actions of `act_dim` values, seeded
    /// from the run's `seed`.
    ///
    /// # Errors
    /// [`RlError::Config`] if a hyperparameter is out of range.
    pub fn build(&self, obs_dim: usize, act_dim: usize, seed: u64) -> Result<Box<dyn Agent>, RlError> {
        Ok(match self {
            Self::Sac(c) => Box::new(Sac::new(c.clone(), obs_dim, act_dim, seed)?),
            Self::Td3(c) => Box::new(Td3::new(c.clone(), obs_dim, act_dim, seed)?),
        })
    }
}

impl Serialize for AlgoConfig {
    /// Serialises as the bare table of the variant's fields (the `[algo_config]` table).
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Sac(c) => c.serialize(s),
            Self::Td3(c) => c.serialize(s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_algo_config_table_of_the_chosen_algorithm() {
        let doc: toml::Table = toml::from_str("algo = \"td3\"\n[algo_config]\npolicy_delay = 3\n").unwrap();
        let algo: Algo = doc["algo"].as_str().unwrap().parse().unwrap();
        let config = AlgoConfig::deserialize_for(algo, doc["algo_config"].clone()).unwrap();
        assert_eq!(config, AlgoConfig::Td3(Td3Config { policy_delay: 3, ..Td3Config::default() }));
        let err = AlgoConfig::deserialize_for(Algo::Sac, doc["algo_config"].clone()).unwrap_err();
        assert!(err.to_string().contains("policy_delay"), "{err}");
        let written = toml::to_string(&config).unwrap();
        assert!(written.contains("policy_delay = 3"), "{written}");
        assert!("ppo".parse::<Algo>().is_err());
    }
}
