//! Every intervention counted, and a sample checked against what would have happened
//! (docs/SPEC.md, section 15). When a wrapper ends an episode before an action runs (DEFENDER's
//! filtered step, whatever triggered it), the trainer records the intervention; every k-th
//! (`counterfactual_every`) it copies the simulator as the wrapper left it
//! ([`crate::Env::fork`]), executes the action that was stopped, and lets the current
//! exploration policy go on unfiltered in the copy, up to `counterfactual_steps` steps (0: to
//! the horizon), recording whether the episode would have failed (crashed; on a cost task,
//! passed the episode cost limit) and after how many steps.
//!
//! The run itself does not change: the copy is stepped, never the training environment, and
//! the policy draws from a generator of its own per intervention ([`crate::Agent::act_with`],
//! `SeedPurpose::Counterfactual`), so the agent's generator and state are untouched.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::agent::Agent;
use crate::env::Env;
use crate::error::RlError;
use crate::seed::{SeedPurpose, derive_seed};
use crate::space::BoxSpace;

/// One intervention (one episode a wrapper ended), and its check if it was checked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InterventionRecord {
    /// The intervention's index in the run, from 0.
    pub intervention: u64,
    /// The training episode it ended.
    pub episode: u64,
    /// Environment steps taken by the end of that episode (the filtered step included).
    pub total_steps: u64,
    /// The episode's steps, the filtered one included.
    pub episode_steps: u64,
    /// The episode's task cost before the stopped action.
    pub episode_cost: f64,
    /// It was checked (every `counterfactual_every`-th intervention, where the environment can
    /// be copied).
    pub checked: bool,
    /// The unfiltered continuation failed: crashed, or (with a cost limit) the episode's cost
    /// passed the limit. `None` when not checked.
    pub would_fail: Option<bool>,
    /// Steps of the continuation until the failure, the stopped action's step being 1.
    pub steps_to_failure: Option<u64>,
    /// Steps the continuation ran (at most `counterfactual_steps`, or to the horizon).
    pub continuation_steps: u64,
    /// Its summed reward and task cost.
    pub continuation_return: f64,
    /// See `continuation_return`.
    pub continuation_cost: f64,
}

impl InterventionRecord {
    /// Intervention `intervention`, not (yet) checked.
    pub fn new(
        intervention: u64,
        episode: u64,
        total_steps: u64,
        episode_steps: u64,
        episode_cost: f64,
    ) -> Self {
        Self {
            intervention,
            episode,
            total_steps,
            episode_steps,
            episode_cost,
            checked: false,
            would_fail: None,
            steps_to_failure: None,
            continuation_steps: 0,
            continuation_return: 0.0,
            continuation_cost: 0.0,
        }
    }
}

/// `counterfactual` in a run's configuration: which interventions are checked, and how far.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckConfig {
    /// Check every this many interventions (0: none).
    #[serde(default)]
    pub every: u64,
    /// Stop the continuation after this many steps (0: at the horizon).
    #[serde(default)]
    pub max_steps: u64,
    /// An episode fails when its cost passes this (a cost task; set by the run from the task);
    /// `None`: a crash is the failure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost_limit: Option<f64>,
    /// The learner is charged the checked continuation's task cost at the filtered step, at most
    /// this much (a cost critic's bound on one step's cost): the cost the intervention
    /// prevented, by one sample (DEFENDER's `filtered_cost = "continuation"`, docs/SPEC.md
    /// section 14; needs `every = 1`, set by the run). `None`: no charge.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charge_max: Option<f64>,
}

impl CheckConfig {
    /// Nothing is checked (left out of a saved configuration).
    pub fn is_off(&self) -> bool {
        self.every == 0
    }
}

/// The intervention `record` (its counts filled by the caller), checked when its index says so.
///
/// # Errors
/// What the copy of the environment or the agent report.
pub(crate) fn check<A: Agent + ?Sized, E: Env + ?Sized>(
    mut record: InterventionRecord,
    env: &E,
    agent: &mut A,
    space: &BoxSpace,
    stopped_action: &[f64],
    (seed, settings): (u64, CheckConfig),
) -> Result<InterventionRecord, RlError> {
    if settings.every == 0 || !record.intervention.is_multiple_of(settings.every) {
        return Ok(record);
    }
    let Some(mut copy) = env.fork() else {
        return Ok(record);
    };
    let mut rng =
        ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Counterfactual, record.intervention));
    let mut env_action = stopped_action.to_vec();
    let mut action = vec![0.0f32; env_action.len()];
    let (mut ret, mut cost, mut steps) = (0.0, 0.0, 0u64);
    let mut failed_at = None;
    loop {
        let step = copy.step(&env_action)?;
        steps += 1;
        ret += step.reward;
        cost += step.cost;
        let over_limit = settings.cost_limit.is_some_and(|l| record.episode_cost + cost > l);
        let crashed = settings.cost_limit.is_none() && step.terminated && !step.info.unstable;
        if over_limit || crashed {
            failed_at = Some(steps);
            break;
        }
        if step.done() || (settings.max_steps > 0 && steps >= settings.max_steps) {
            break;
        }
        agent.act_with(&step.obs, &mut rng, &mut action)?;
        space.unscale(&action, &mut env_action);
    }
    record.checked = true;
    record.would_fail = Some(failed_at.is_some());
    record.steps_to_failure = failed_at;
    record.continuation_steps = steps;
    record.continuation_return = ret;
    record.continuation_cost = cost;
    Ok(record)
}
