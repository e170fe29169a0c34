//! Evaluating the deterministic policy: its episodes on the evaluation environment, and, for a run
//! whose training environment lends a [`Shield`] (DEFENDER's filter, [`crate::Env::shield`]), the
//! same episodes again with the shield kept, as it would be deployed (docs/SPEC.md, section 6).
//!
//! ```text
//! seeds = the evaluation's reset seeds (the trainer's evaluation counter moves on by their number)
//! unfiltered: for each seed: reset(seed); act deterministically until the episode ends
//! shielded:   for each seed (the same ones): reset(seed); shield.reset()
//!             per step: the shield sees (s_t, a_t); refused -> the episode stops there,
//!             the action is not executed; else step as above
//! ```
//!
//! A paired comparison: episode k of both passes starts from the same state, so the two differ
//! only by what the shield stops. A stopped episode's return, cost and length are those of its
//! executed steps: a filtered step has no reward (nothing reached the environment, and no
//! dynamics model stands in for it here).

use serde::{Deserialize, Serialize};

use crate::agent::Agent;
use crate::env::Env;
use crate::error::RlError;
use crate::shield::Shield;
use crate::space::BoxSpace;

/// One evaluation of the deterministic policy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalRecord {
    /// Training steps when it ran.
    pub total_steps: u64,
    /// Mean undiscounted return.
    pub mean_return: f64,
    /// Population standard deviation of the returns (numpy's default, as SB3 reports).
    pub std_return: f64,
    /// Mean episode length.
    pub mean_length: f64,
    /// Mean episode cost (`None` in records written before costs existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_cost: Option<f64>,
    /// Episodes run.
    pub episodes: usize,
    /// Each episode's return.
    pub returns: Vec<f64>,
    /// Each episode's cost (empty in records written before they were kept).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub costs: Vec<f64>,
    /// This is the end-of-training evaluation.
    pub is_final: bool,
    /// The same episodes with the training environment's shield kept; `None` for a run without
    /// one (every run but DEFENDER's) and in records written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shield: Option<ShieldedEval>,
}

/// The shielded pass of an evaluation: its episodes are the unfiltered pass's (the same reset
/// seeds, as many), each stopped at the first step the shield refuses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShieldedEval {
    /// Mean undiscounted return over the executed steps.
    pub mean_return: f64,
    /// Population standard deviation of the returns.
    pub std_return: f64,
    /// Mean number of executed steps.
    pub mean_length: f64,
    /// Mean cost over the executed steps.
    pub mean_cost: f64,
    /// Share of the episodes that the shield stopped (0 to 1).
    pub filtered: f64,
    /// Each episode's return.
    pub returns: Vec<f64>,
    /// Each episode's cost over its executed steps (empty in records written before).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub costs: Vec<f64>,
    /// Whether the shield stopped each episode (empty in records written before).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stopped: Vec<bool>,
}

/// The sums of one pass over the evaluation's seeds.
struct Pass {
    returns: Vec<f64>,
    lengths: Vec<f64>,
    costs: Vec<f64>,
    /// Summed over every step of every episode, in order (as the first evaluations did).
    total_cost: f64,
    stopped: Vec<bool>,
}

impl Pass {
    fn mean_return(&self) -> f64 {
        self.returns.iter().sum::<f64>() / self.returns.len() as f64
    }

    fn std_return(&self) -> f64 {
        let (n, mean) = (self.returns.len() as f64, self.mean_return());
        (self.returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt()
    }

    fn mean_length(&self) -> f64 {
        self.lengths.iter().sum::<f64>() / self.lengths.len() as f64
    }

    fn mean_cost(&self) -> f64 {
        self.total_cost / self.returns.len() as f64
    }
}

/// The policy, the environment it is evaluated on, and the training environment's action bounds.
pub(crate) struct Evaluator<'a, A: ?Sized, V: ?Sized> {
    pub(crate) agent: &'a mut A,
    pub(crate) env: &'a mut V,
    pub(crate) action_space: &'a BoxSpace,
}

impl<A: Agent + ?Sized, V: Env + ?Sized> Evaluator<'_, A, V> {
    /// Runs one episode per seed of `seeds` (at least one), then, with a `shield`, the same
    /// episodes shielded; `total_steps` and `is_final` label the record.
    ///
    /// # Errors
    /// What the agent, the environment or the shield report.
    pub(crate) fn evaluate(
        &mut self,
        seeds: &[u64],
        shield: Option<Box<dyn Shield>>,
        total_steps: u64,
        is_final: bool,
    ) -> Result<EvalRecord, RlError> {
        let plain = self.pass(seeds, None)?;
        let shield = match shield {
            Some(mut shield) => {
                let pass = self.pass(seeds, Some(&mut *shield))?;
                Some(ShieldedEval {
                    mean_return: pass.mean_return(),
                    std_return: pass.std_return(),
                    mean_length: pass.mean_length(),
                    mean_cost: pass.mean_cost(),
                    filtered: pass.stopped.iter().filter(|&&s| s).count() as f64 / seeds.len() as f64,
                    returns: pass.returns,
                    costs: pass.costs,
                    stopped: pass.stopped,
                })
            }
            None => None,
        };
        Ok(EvalRecord {
            total_steps,
            mean_return: plain.mean_return(),
            std_return: plain.std_return(),
            mean_length: plain.mean_length(),
            mean_cost: Some(plain.mean_cost()),
            episodes: seeds.len(),
            returns: plain.returns,
            costs: plain.costs,
            is_final,
            shield,
        })
    }

    /// One deterministic episode per seed; with a shield, each stops before the first action it
    /// refuses.
    fn pass(&mut self, seeds: &[u64], mut shield: Option<&mut dyn Shield>) -> Result<Pass, RlError> {
        let act_dim = self.agent.act_dim();
        let mut action = vec![0.0f32; act_dim];
        let mut env_action = vec![0.0f64; act_dim];
        let mut pass = Pass {
            returns: Vec::with_capacity(seeds.len()),
            lengths: Vec::with_capacity(seeds.len()),
            costs: Vec::with_capacity(seeds.len()),
            total_cost: 0.0,
            stopped: Vec::with_capacity(seeds.len()),
        };
        for &seed in seeds {
            let mut obs = self.env.reset(Some(seed))?;
            if let Some(shield) = shield.as_deref_mut() {
                shield.reset();
            }
            let (mut ret, mut len, mut cost, mut stopped) = (0.0, 0u64, 0.0, false);
            loop {
                self.agent.act(&obs, true, &mut action)?;
                self.action_space.unscale(&action, &mut env_action);
                if let Some(shield) = shield.as_deref_mut()
                    && !shield.allows(&obs, &env_action)?
                {
                    stopped = true;
                    break;
                }
                let step = self.env.step(&env_action)?;
                ret += step.reward;
                pass.total_cost += step.cost;
                cost += step.cost;
                len += 1;
                if step.done() {
                    break;
                }
                obs = step.obs;
            }
            pass.returns.push(ret);
            pass.lengths.push(len as f64);
            pass.costs.push(cost);
            pass.stopped.push(stopped);
        }
        Ok(pass)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_written_before_the_shield_existed_reads_without_one() {
        let old = r#"{"total_steps":10,"mean_return":1.5,"std_return":0.5,"mean_length":3.0,
            "mean_cost":0.0,"episodes":2,"returns":[1.0,2.0],"is_final":false}"#;
        let record: EvalRecord = serde_json::from_str(old).unwrap();
        assert_eq!((record.total_steps, &record.shield), (10, &None));
        let text = serde_json::to_string(&record).unwrap();
        assert!(!text.contains("shield"), "a record without a shield writes none: {text}");
        let shielded = EvalRecord {
            shield: Some(ShieldedEval {
                mean_return: 1.0,
                std_return: 0.0,
                mean_length: 2.0,
                mean_cost: 0.5,
                filtered: 0.5,
                returns: vec![1.0, 1.0],
                costs: vec![0.0, 1.0],
                stopped: vec![true, false],
            }),
            ..record
        };
        let back: EvalRecord = serde_json::from_str(&serde_json::to_string(&shielded).unwrap()).unwrap();
        assert_eq!(back, shielded);
    }
}
