//! Seeds: every random stream of a run is derived from the run's seed and a purpose.

/// What a derived seed is for; one stream per purpose, so that adding draws to one stream
/// never shifts another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeedPurpose {
    /// Initial network weights.
    Init,
    /// The agent's sampling (exploration, batches, policy noise).
    Agent,
    /// The reset of training episode `index`.
    TrainEpisode,
    /// The reset of evaluation episode `index` (counted over all evaluations of the run).
    EvalEpisode,
    /// An environment wrapper's own model (DEFENDER's dynamics model: weights and sampling).
    Wrapper,
    /// Episodes run outside training, e.g. the demonstration of the policy after episode `index`.
    Demonstration,
    /// The policy's draws in the counterfactual continuation of intervention `index`
    /// (crate::counterfactual).
    Counterfactual,
}

/// SplitMix64's finaliser: a bijection that scatters nearby inputs.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed for `(run seed, purpose, index)`: distinct for distinct inputs with overwhelming
/// probability, and the same on every machine.
pub fn derive_seed(seed: u64, purpose: SeedPurpose, index: u64) -> u64 {
    let p = match purpose {
        SeedPurpose::Init => 1,
        SeedPurpose::Agent => 2,
        SeedPurpose::TrainEpisode => 3,
        SeedPurpose::EvalEpisode => 4,
        SeedPurpose::Wrapper => 5,
        SeedPurpose::Demonstration => 6,
        SeedPurpose::Counterfactual => 7,
    };
    mix(mix(mix(seed) ^ p) ^ index)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ() {
        let a = derive_seed(0, SeedPurpose::TrainEpisode, 0);
        assert_ne!(a, derive_seed(0, SeedPurpose::TrainEpisode, 1));
        assert_ne!(a, derive_seed(1, SeedPurpose::TrainEpisode, 0));
        assert_ne!(a, derive_seed(0, SeedPurpose::EvalEpisode, 0));
        assert_eq!(a, derive_seed(0, SeedPurpose::TrainEpisode, 0));
    }
}
