//! The agent of a run with its `[safety]` baseline (defender_rl::safety) around or inside it.

use anyhow::{Result, bail};
use defender_config::run_config::RunConfig;
use defender_rl::safety::lagrangian::LagrangianSac;
use defender_rl::safety::penalty::Penalized;
use defender_rl::{Agent, AlgoConfig, SafetyConfig};

/// The run's agent: the configured algorithm, learning from costs as `[safety]` says. With
/// `risk_signal` (DEFENDER's `risk-critic` trigger), Recovery RL raises it instead of acting
/// with its recovery policy.
pub fn build_agent(
    config: &RunConfig,
    algo: &AlgoConfig,
    (obs_dim, act_dim): (usize, usize),
    seed: u64,
    risk_signal: Option<defender_rl::RiskSignal>,
) -> Result<Box<dyn Agent>> {
    if let Some(SafetyConfig::Recovery(recovery)) = &config.safety {
        let agent = crate::recovery_agent::build_recovery(recovery, algo, obs_dim, act_dim, seed)?;
        return Ok(match risk_signal {
            Some(signal) => Box::new(agent.ending_episodes(signal)),
            None => Box::new(agent),
        });
    }
    if let Some(SafetyConfig::Lagrangian(lagrangian)) = &config.safety {
        let AlgoConfig::Sac(sac) = algo else {
            bail!(
                "[safety] method = \"lagrangian\" is Lagrangian SAC: it needs algo = \"sac\", not \"{}\"",
                algo.algo()
            );
        };
        return Ok(Box::new(LagrangianSac::new(sac.clone(), lagrangian.clone(), obs_dim, act_dim, seed)?));
    }
    if let Some(SafetyConfig::Pid(pid)) = &config.safety {
        let AlgoConfig::Sac(sac) = algo else {
            bail!(
                "[safety] method = \"pid\" is PID Lagrangian SAC: it needs algo = \"sac\", not \"{}\"",
                algo.algo()
            );
        };
        return Ok(Box::new(LagrangianSac::pid(sac.clone(), pid.clone(), obs_dim, act_dim, seed)?));
    }
    let agent = algo.build(obs_dim, act_dim, seed)?;
    Ok(match &config.safety {
        None => agent,
        Some(SafetyConfig::Penalty { penalty }) => Box::new(Penalized::new(agent, *penalty)),
        // Both are built above.
        Some(SafetyConfig::Lagrangian(_) | SafetyConfig::Pid(_) | SafetyConfig::Recovery(_)) => agent,
    })
}
