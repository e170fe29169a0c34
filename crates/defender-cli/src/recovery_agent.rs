//! Recovery RL in a run (defender_rl::safety::recovery): its agent around SAC, and the
//! demonstration set it pretrains its safety critic on, which a run without `[defender]` reads
//! from the top-level `demos` key or the set shipped for the task, as `demos_in_replay` does.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use defender_config::run_config::RunConfig;
use defender_config::shipped_demos;
use defender_rl::safety::RecoveryConfig;
use defender_rl::safety::recovery::Recovery;
use defender_rl::{AlgoConfig, Sac, SafetyConfig};

/// Recovery RL around the run's SAC, as a run builds it (`defender demos risk-horizon` measures
/// this agent's safety critic). Their task learner is SAC and the safety critic's target samples
/// the task policy, so TD3 is refused, naming the key.
pub fn build_recovery(
    recovery: &RecoveryConfig,
    algo: &AlgoConfig,
    obs_dim: usize,
    act_dim: usize,
    seed: u64,
) -> Result<Recovery> {
    let AlgoConfig::Sac(sac) = algo else {
        bail!(
            "algo = \"{}\": [safety] method = \"recovery\" wraps SAC (the task learner of Recovery RL's \
             code); set algo = \"sac\"",
            algo.algo()
        );
    };
    let task = Sac::new(sac.clone(), obs_dim, act_dim, seed)?;
    Recovery::new(task, recovery.clone(), seed).context("[safety]")
}

/// Whether the run is Recovery RL, which needs the demonstrations whatever `demos_in_replay` says.
pub fn needs_demos(config: &RunConfig) -> bool {
    matches!(config.safety, Some(SafetyConfig::Recovery(_)))
}

/// The demonstration file a run without `[defender]` stores before training: `demos`, else the
/// set shipped for the task, when the agent keeps demonstrations in its buffer or the run is
/// Recovery RL; `None` otherwise.
///
/// # Errors
/// Neither file is known (or Recovery RL's does not exist), naming the key that asks for it.
pub fn bare_demos(config: &RunConfig, demos_in_replay: bool) -> Result<Option<PathBuf>> {
    let env_id = config.env.as_str();
    let found = config.demos.clone().or_else(|| shipped_demos(env_id));
    if needs_demos(config) {
        return match found {
            Some(path) if config.demos.is_some() || path.exists() => Ok(Some(path)),
            _ => bail!(
                "[safety] method = \"recovery\": Recovery RL pretrains its safety critic on \
                 demonstrations and none are shipped for {env_id}; give the top-level `demos` key \
                 (make a set with `defender demos collect --env {env_id} --out FILE.npz`)"
            ),
        };
    }
    if !demos_in_replay {
        return Ok(None);
    }
    found.map(Some).with_context(|| {
        format!("demos_in_replay: no demonstrations shipped for {env_id}; give the top-level `demos` key")
    })
}
