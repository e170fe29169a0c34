//! Recovery RL, model-free (Thananjeyan et al. 2021): the task agent (SAC) proposes an action;
//! when the safety critic judges it too risky, `Q_risk(s, a) > eps_risk`, the recovery policy's
//! action is executed instead.
//!
//! ```text
//! before training: pretrain_steps gradient steps of Q_risk and the recovery policy on the
//!                  demonstrations (their crashes are the violations); never again on resume
//! each step:       a = pi_task(s); if Q_risk(s, a) > eps_risk { a_exec = pi_rec(s) } else { a }
//!                  task buffer   <- (s, a,      r, s')        (the proposed action: relabelling)
//!                  Q_risk buffer <- (s, a_exec, c, s')        (the executed one)
//!                  after each task gradient step, one of Q_risk and the recovery policy
//! evaluation:      the task policy alone (the recovery layer is a training-time shield)
//! ```
//!
//! The task agent, its buffer, generator and schedule, is SAC unchanged; the safety critic and
//! the recovery policy live beside it ([`super::risk_critic`]). docs/decisions.md, "Recovery
//! RL", gives each choice and its source.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::RecoveryConfig;
use super::risk_critic::{RiskCritic, RiskShape, RiskState};
use crate::agent::{Agent, UpdateStats};
use crate::checkpoint::{read_json, write_json};
use crate::error::RlError;
use crate::nets::obs_to_f32;
use crate::replay::Transition;
use crate::sac::Sac;

/// The sub-directory of the agent's checkpoint directory with the safety critic's files (the
/// task agent's stay where a plain SAC run keeps them).
const RISK_DIR: &str = "recovery";

/// What `recovery/state.json` holds besides the networks and the buffer.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RecoveryState {
    config: RecoveryConfig,
    obs_dim: usize,
    act_dim: usize,
    /// Pretraining gradient steps done (`pretrain_steps` once training began).
    pretrained_steps: u64,
    /// The task agent's gradient steps the safety critic has matched.
    task_updates: u64,
    recovery_steps: u64,
    risk: RiskState,
}

/// Whether the recovery policy takes over from an action of risk `q_risk`: strictly above
/// `eps_risk`, as their `critic_val > eps_safe`, compared in the critic's precision. Offline
/// measurements of the switch (`defender demos risk-horizon`) use the same rule.
pub fn too_risky(q_risk: f32, eps_risk: f64) -> bool {
    q_risk > eps_risk as f32
}

/// The proposed action of the last exploration step, until its transition is observed.
#[derive(Debug, Clone)]
struct Proposal {
    obs: Vec<f64>,
    action: Vec<f32>,
    live: bool,
}

/// A SAC agent shielded by Recovery RL's safety critic and recovery policy.
#[derive(Debug, Clone)]
pub struct Recovery {
    task: Sac,
    risk: RiskCritic,
    config: RecoveryConfig,
    pretrained_steps: u64,
    task_updates: u64,
    recovery_steps: u64,
    proposal: Proposal,
    obs1: Vec<f32>,
    /// The `risk-critic` trigger: raised for a risky proposal instead of acting with the recovery
    /// policy (`None`: Recovery RL as published).
    end_signal: Option<super::risk_signal::RiskSignal>,
    /// The last proposal raised the signal: its transition never happened (the environment ended
    /// the episode without executing it) and stays out of the safety critic's buffer.
    ended: bool,
}

impl Recovery {
    /// Recovery RL around `task`, with the task agent's hidden layers, learning rate, batch
    /// size and buffer capacity for the safety critic and the recovery policy; their weights
    /// and sampling derive from `seed`.
    ///
    /// # Errors
    /// [`RlError::Config`] naming a bad setting.
    pub fn new(task: Sac, config: RecoveryConfig, seed: u64) -> Result<Self, RlError> {
        super::SafetyConfig::Recovery(config.clone()).validate()?;
        let (o, a) = (task.obs_dim(), task.act_dim());
        let c = task.config();
        let shape = RiskShape {
            obs_dim: o,
            act_dim: a,
            net_arch: c.net_arch.clone(),
            learning_rate: c.learning_rate,
            batch_size: c.batch_size,
            buffer_size: c.buffer_size,
            gamma_risk: config.gamma_risk as f32,
            pos_fraction: config.pos_fraction,
        };
        Ok(Self {
            risk: RiskCritic::new(shape, seed)?,
            task,
            config,
            pretrained_steps: 0,
            task_updates: 0,
            recovery_steps: 0,
            proposal: Proposal { obs: vec![0.0; o], action: vec![0.0; a], live: false },
            obs1: vec![0.0; o],
            end_signal: None,
            ended: false,
        })
    }

    /// The safety critic as DEFENDER's `risk-critic` trigger (docs/SPEC.md, section 15): a risky
    /// exploration action raises `signal` and is proposed unchanged, so that the environment
    /// holding the signal ends the episode; the recovery policy never acts. The steps so ended
    /// are counted as `recovery_steps`. The critic learns from executed steps only.
    pub fn ending_episodes(mut self, signal: super::risk_signal::RiskSignal) -> Self {
        self.end_signal = Some(signal);
        self
    }

    /// The task agent.
    pub fn task(&self) -> &Sac {
        &self.task
    }

    /// Environment steps so far in which the recovery policy acted.
    pub fn recovery_steps(&self) -> u64 {
        self.recovery_steps
    }

    /// Gradient steps of the safety critic so far, the pretraining's included.
    pub fn risk_updates(&self) -> u64 {
        self.risk.n_updates
    }

    /// Whether the pretraining on the demonstrations is done.
    pub fn pretrained(&self) -> bool {
        self.pretrained_steps >= self.config.pretrain_steps
    }

    /// `Q_risk(obs, action)` by the current safety critic.
    ///
    /// # Errors
    /// A vector of the wrong length or a non-finite observation.
    pub fn risk(&mut self, obs: &[f64], action: &[f32]) -> Result<f32, RlError> {
        obs_to_f32(obs, &mut self.obs1)?;
        crate::nets::check_action_len(action, self.task.act_dim())?;
        Ok(self.risk.value(&self.obs1, action))
    }

    /// Pretrains the safety critic and the recovery policy on the transitions stored so far
    /// (the demonstrations), if not done yet; the first exploration step calls it.
    ///
    /// # Errors
    /// [`RlError::Config`] naming `demos` when no demonstration was stored.
    pub fn pretrain(&mut self) -> Result<(), RlError> {
        if self.pretrained() {
            return Ok(());
        }
        if self.risk.buffer.is_empty() {
            return Err(RlError::Config {
                field: "demos",
                value: "none stored".into(),
                expected: "a demonstration set: Recovery RL pretrains its safety critic on it",
            });
        }
        while self.pretrained_steps < self.config.pretrain_steps {
            self.risk.gradient_step(&mut self.task)?;
            self.pretrained_steps += 1;
        }
        Ok(())
    }
}

impl Agent for Recovery {
    fn algo(&self) -> &'static str {
        self.task.algo()
    }
    fn obs_dim(&self) -> usize {
        self.task.obs_dim()
    }
    fn act_dim(&self) -> usize {
        self.task.act_dim()
    }
    fn num_timesteps(&self) -> u64 {
        self.task.num_timesteps()
    }

    /// Evaluation (`deterministic`) is the task policy's alone; exploration is shielded.
    fn act(&mut self, obs: &[f64], deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        if deterministic {
            return self.task.act(obs, true, action);
        }
        self.pretrain()?;
        self.task.act(obs, false, action)?;
        obs_to_f32(obs, &mut self.obs1)?;
        self.proposal.obs.copy_from_slice(obs);
        self.proposal.action.copy_from_slice(action);
        self.proposal.live = true;
        let risky = too_risky(self.risk.value(&self.obs1, action), self.config.eps_risk);
        if let Some(signal) = &self.end_signal {
            signal.set(risky);
            self.ended = risky;
            self.recovery_steps += u64::from(risky);
        } else if risky {
            self.risk.policy.act(&self.obs1, false, &mut self.risk.rng, action);
            self.recovery_steps += 1;
        }
        Ok(())
    }

    /// The task policy's exploration action (the counterfactual check runs only where the
    /// recovery policy never acts: the `risk-critic` trigger).
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError> {
        self.task.act_with(obs, rng, action)
    }

    /// The task agent stores the action it proposed, the safety critic the one executed
    /// (`transition.action`). A transition not preceded by an exploration step on its state
    /// (a caller feeding transitions directly) was proposed as executed.
    fn observe(&mut self, transition: &Transition<'_>) -> Result<(), RlError> {
        let proposed = self.proposal.live && self.proposal.obs == transition.obs;
        self.proposal.live = false;
        let task =
            if proposed { Transition { action: &self.proposal.action, ..*transition } } else { *transition };
        self.task.observe(&task)?;
        if std::mem::take(&mut self.ended) && proposed {
            return Ok(());
        }
        self.risk.push(transition)
    }

    /// A demonstration is the safety critic's offline data (their `constraint_demo_data`); the
    /// task agent stores it too when its configuration asks (`demos_in_replay`).
    fn store_demonstration(&mut self, transition: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        if self.task.config().demos_in_replay {
            self.task.store_demonstration(transition, bc)?;
        }
        self.risk.push(transition)
    }

    /// The task agent's scheduled steps, then as many of the safety critic and the recovery
    /// policy (their code updates `Q_risk` once per task update, online as during pretraining).
    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        let Some(mut stats) = self.task.update()? else {
            return Ok(None);
        };
        while self.task_updates < stats.n_updates {
            self.risk.gradient_step(&mut self.task)?;
            self.task_updates += 1;
        }
        stats.recovery_steps = Some(self.recovery_steps);
        Ok(Some(stats))
    }

    fn save(&self, dir: &Path) -> Result<(), RlError> {
        self.task.save(dir)?;
        let risk_dir = dir.join(RISK_DIR);
        std::fs::create_dir_all(&risk_dir).map_err(|e| RlError::io(&risk_dir, e))?;
        self.risk.save(&risk_dir)?;
        let state = RecoveryState {
            config: self.config.clone(),
            obs_dim: self.obs_dim(),
            act_dim: self.act_dim(),
            pretrained_steps: self.pretrained_steps,
            task_updates: self.task_updates,
            recovery_steps: self.recovery_steps,
            risk: self.risk.state(),
        };
        write_json(&risk_dir.join("state.json"), &state)
    }

    fn load(&mut self, dir: &Path) -> Result<(), RlError> {
        self.task.load(dir)?;
        let risk_dir = dir.join(RISK_DIR);
        let path = risk_dir.join("state.json");
        let state: RecoveryState = read_json(&path)?;
        if state.config != self.config || (state.obs_dim, state.act_dim) != (self.obs_dim(), self.act_dim()) {
            return Err(RlError::checkpoint(
                &path,
                format!(
                    "saved by Recovery RL with {:?} and dims {}/{}, this agent has {:?} and {}/{}",
                    state.config,
                    state.obs_dim,
                    state.act_dim,
                    self.config,
                    self.obs_dim(),
                    self.act_dim()
                ),
            ));
        }
        self.risk.load(&risk_dir, state.risk, &path)?;
        self.pretrained_steps = state.pretrained_steps;
        self.task_updates = state.task_updates;
        self.recovery_steps = state.recovery_steps;
        self.proposal.live = false;
        self.ended = false;
        Ok(())
    }

    /// The learned policy is the task policy (the one evaluated).
    fn save_actor(&self, path: &Path) -> Result<(), RlError> {
        self.task.save_actor(path)
    }
}

#[cfg(test)]
#[path = "recovery_tests.rs"]
mod tests;
