//! The task a collection runs on, and one recorded episode of the current policy.

use anyhow::{Result, bail};
use defender::{EpisodeRecorder, UnsafeRule, ViolationTracker};
use defender_mujoco::MujocoEnv;
use defender_rl::{Agent, Env, TimeLimit};

use super::CollectArgs;

/// The task with the horizon `--max-episode-steps` gives (the task's own by default).
pub(crate) fn make_env(args: &CollectArgs) -> Result<TimeLimit<MujocoEnv>> {
    let env = defender_mujoco::make(&args.env)?;
    Ok(match args.max_episode_steps {
        Some(0) => bail!("--max-episode-steps must be >= 1"),
        Some(n) => TimeLimit::new(env.into_inner(), n),
        None => env,
    })
}

/// The rule that labels a collection's episodes on this task: the crash, or on a task with a
/// per-step cost, the episode cost passing `--episode-cost-limit` (the task's limit by default).
pub(crate) fn unsafe_rule(args: &CollectArgs, env: &TimeLimit<MujocoEnv>) -> Result<UnsafeRule> {
    let task_limit = env.inner().task().cost().episode_limit();
    match (args.episode_cost_limit, task_limit) {
        (Some(l), None) => bail!(
            "--episode-cost-limit {l}: {}'s safety is a crash, not a per-step cost; leave it out",
            args.env
        ),
        (given, task) => Ok(UnsafeRule::from_limit(given.or(task))?),
    }
}

/// Records one episode of the agent's policy (deterministic or stochastic) on `env`, reset with
/// `seed`, into `recorder` (left to be finished by the caller) and labels it by `rule`:
/// `Some(true)` unsafe, `Some(false)` safe, `None` neither (it ended early without a violation:
/// a fall on a cost task). An unsafe episode stops on the step that made it so (crate
/// `defender`'s `violation` module): the demonstration is the episode up to its violation.
pub(crate) fn record_episode(
    env: &mut TimeLimit<MujocoEnv>,
    agent: &mut dyn Agent,
    recorder: &mut EpisodeRecorder,
    seed: u64,
    deterministic: bool,
    rule: UnsafeRule,
) -> Result<Option<bool>> {
    let mut tracker = ViolationTracker::new(rule);
    let mut obs = env.reset(Some(seed))?;
    recorder.start(&obs);
    let space = env.action_space().clone();
    let mut action = vec![0.0f32; space.dim()];
    let mut env_action = vec![0.0f64; space.dim()];
    loop {
        agent.act(&obs, deterministic, &mut action)?;
        // [-1, 1] -> the action bounds, as the trainer does.
        space.unscale(&action, &mut env_action);
        let step = env.step(&env_action)?;
        recorder.step(&env_action, step.reward, &step.obs)?;
        let violated = tracker.step(step.cost, step.terminated);
        if violated || step.done() {
            return Ok(tracker.label(step.truncated && !step.terminated));
        }
        obs = step.obs;
    }
}
