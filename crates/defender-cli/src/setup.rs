//! Building a run from its configuration: the task, DEFENDER around it, the agent; and the
//! recorder of its training episodes (`--record-episodes`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use defender::selection::StrategyChoice;
use defender::{DefenderEnv, EpisodeRecorder, EpisodeSet, Meta};
use defender_rl::{Agent, Env, EpisodeRecord, Outcome, Parallelism, SeedPurpose, Transition, derive_seed};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use defender_config::run_config::{DefenderSection, RunConfig};
use defender_config::shipped_demos;

/// The ids of the tasks a run may name (the simulator's registry), for the experiment files.
pub fn task_ids() -> Vec<&'static str> {
    defender_mujoco::TASKS.iter().map(|t| t.id).collect()
}

/// The episode cost limit of task `env_id` (`None`: a crash task, or an unknown id, which
/// building the run then names).
pub fn task_cost_limit(env_id: &str) -> Option<f64> {
    defender_mujoco::Task::from_id(env_id).ok().and_then(|t| t.cost().episode_limit())
}

/// A built run: the agent, the training environment (DEFENDER around the task when configured),
/// the unfiltered evaluation environment, and DEFENDER's section as resolved.
pub struct Built {
    /// The agent.
    pub agent: Box<dyn Agent>,
    /// The training environment.
    pub env: Box<dyn Env>,
    /// The evaluation environment (never filtered: SPEC section 6).
    pub eval_env: Box<dyn Env>,
    /// The `[defender]` section with what building it resolved: `R_task`, the demonstration file
    /// and its SHA-256, `num_demos`, and the strategy `auto` chose (`None` for a bare run).
    pub defender: Option<DefenderSection>,
    /// DEFENDER's dynamics model, read apart from the training environment (for `dynamics.csv`).
    pub dynamics: Option<defender::DynamicsHandle>,
    /// A bare run's demonstration file stored in the agent's buffer (or Recovery RL's), and its
    /// SHA-256.
    pub replay_demos: Option<(PathBuf, String)>,
    /// DEFENDER's alignment costs as the run goes (for its TensorBoard scalars).
    pub costs: Option<crate::cost_meter::SharedCosts>,
}

/// Whether a run trains DEFENDER's dynamics model on a thread of its own: when its configuration
/// asks (`background = true`), and whenever the networks use two or more threads. The model
/// learns the same bit for bit either way (`crates/defender/src/dynamics_worker.rs`), so this
/// is a matter of speed only, like the networks' threads: with two, the model's small products
/// inline leave the second core waiting, on its own thread they fill it (98% against 108-111%
/// Time; docs/decisions.md, "The dynamics model on its own thread"). With one network thread (a
/// sweep's runs, one core each) the model stays inline, off the other runs' core.
pub fn model_on_own_thread(requested: bool, networks: Parallelism) -> bool {
    requested || networks.num_threads() >= 2
}

/// Builds the agent and the environments of a run, and returns with them the `[defender]` section
/// as resolved, so that `config.toml` records what was used. An agent with `demos_in_replay`
/// gets every transition of the run's demonstration set in its buffer first.
pub fn build(config: &RunConfig) -> Result<Built> {
    let (env_id, seed) = (config.env.as_str(), config.seed);
    let algo = config.algo_config();
    // Recovery RL pretrains on the demonstrations whatever `demos_in_replay` says.
    let recovery = crate::recovery_agent::needs_demos(config);
    let task = defender_mujoco::make(env_id)?;
    let task_limit = task.inner().task().cost().episode_limit();
    config.check_for_task(task_limit)?;
    let (obs_dim, act_dim) = (task.observation_space().dim(), task.action_space().dim());
    let action_space = task.action_space().clone();
    let eval_env: Box<dyn Env> = Box::new(defender_mujoco::make(env_id)?);
    let risk_signal = config
        .defender
        .as_ref()
        .filter(|d| d.filter.trigger == defender::TriggerKind::RiskCritic)
        .map(|_| defender_rl::RiskSignal::new());
    let mut agent =
        crate::safety_agent::build_agent(config, &algo, (obs_dim, act_dim), seed, risk_signal.clone())?;
    let Some(section) = config.defender.as_ref() else {
        let mut replay_demos = None;
        if let Some(path) = crate::recovery_agent::bare_demos(config, algo.demos_in_replay())? {
            let (demos, sha256) = load_pinned(&path, config.demos_sha256.as_deref())?;
            demos.check_env(env_id, obs_dim, act_dim)?;
            preload(&mut *agent, &demos, &action_space)?;
            replay_demos = Some((path, sha256));
        }
        return Ok(Built {
            agent,
            env: Box::new(task),
            eval_env,
            defender: None,
            dynamics: None,
            costs: None,
            replay_demos,
        });
    };
    if config.demos.is_some() {
        bail!("a DEFENDER run takes its demonstrations from [defender] demos, not the top-level `demos` key");
    }
    let mut section = section.clone();
    // On a cost task an episode is unsafe past the task's limit unless the run sets its own.
    section.episode_cost_limit = section.episode_cost_limit.or(task_limit);
    let path = demos_path(env_id, section.demos.as_deref())?;
    let sha256 = file_sha256(&path)?;
    if let Some(pinned) = &section.demos_sha256
        && *pinned != sha256
    {
        bail!(
            "{}: the demonstrations changed since the run was configured (SHA-256 {sha256}, the \
             configuration pins {pinned}); restore the file, or start a new run",
            path.display()
        );
    }
    let demos = EpisodeSet::load(&path)?;
    if let Some(warning) =
        task.max_episode_steps().and_then(|h| crate::demo_horizon::warning(&demos, h, section.num_demos))
    {
        note!("warning: {}: {warning}", path.display());
    }
    if section.strategy == StrategyChoice::Auto {
        let (strategy, scaling, record) = crate::commands::select::choose_for_run(
            &demos,
            section.mode,
            section.num_demos,
            section.cost.given(),
        )?;
        section.strategy = strategy.into();
        section.cost.scaling = Some(scaling);
        section.selection = Some(record);
    }
    // config.toml names the scaling used, given or not.
    section.cost.scaling.get_or_insert_default();
    let mut config = section.to_config()?;
    config.dynamics.background = model_on_own_thread(config.dynamics.background, Parallelism::default());
    let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Wrapper, 0));
    let mut wrapped = DefenderEnv::new(task, &demos, config, &mut rng)?;
    if let Some(signal) = risk_signal {
        wrapped.set_risk_signal(signal)?;
    }
    section.r_task = Some(wrapped.r_task());
    section.demos = Some(path);
    section.demos_sha256 = Some(sha256);
    if section.num_demos.is_none() {
        section.num_demos = Some(demos.group_sizes().0.min(demos.group_sizes().1));
    }
    let dynamics = Some(wrapped.dynamics_handle());
    if algo.demos_in_replay() || recovery {
        preload(&mut *agent, &demos, &action_space)?;
    }
    let (metered, costs) = crate::cost_meter::CostMeter::new(wrapped);
    Ok(Built {
        agent,
        env: Box::new(metered),
        eval_env,
        defender: Some(section),
        dynamics,
        costs: Some(costs),
        replay_demos: None,
    })
}

/// The demonstration file of a DEFENDER run on `env_id`: the one it names, else the one shipped
/// for the task.
///
/// # Errors
/// No file named and none shipped for the task.
pub fn demos_path(env_id: &str, named: Option<&Path>) -> Result<PathBuf> {
    match (named, shipped_demos(env_id)) {
        (Some(path), _) => Ok(path.to_path_buf()),
        (None, Some(path)) if path.exists() => Ok(path),
        (None, looked) => {
            let looked = looked.map_or("an installed defender carries none".into(), |p| {
                format!("looked for {}", p.display())
            });
            bail!(
                "no demonstrations shipped for {env_id} ({looked}); give --demos FILE.npz (make one \
                 with `defender demos collect --env {env_id} --out FILE.npz`), or set DEFENDER_DATA \
                 to a folder holding demos/{env_id}.npz (the repository's data/)"
            )
        }
    }
}

/// A demonstration file and its SHA-256, refused if `pinned` names another content.
fn load_pinned(path: &Path, pinned: Option<&str>) -> Result<(EpisodeSet, String)> {
    let sha256 = file_sha256(path)?;
    if let Some(pinned) = pinned
        && pinned != sha256
    {
        bail!(
            "{}: the demonstrations changed since the run was configured (SHA-256 {sha256}, the \
             configuration pins {pinned}); restore the file, or start a new run",
            path.display()
        );
    }
    Ok((EpisodeSet::load(path)?, sha256))
}

/// Every transition of every demonstration of `set` into the agent's replay buffer (the
/// authors' `demos_in_replay`), actions normalised to [-1, 1] as the trainer stores them. The
/// last transition of a crashed demonstration is terminal, that of a safe one a time-limit cut;
/// a safe demonstration's transitions are marked for behaviour cloning.
pub(crate) fn preload(agent: &mut dyn Agent, set: &EpisodeSet, space: &defender_rl::BoxSpace) -> Result<()> {
    let mut action = vec![0.0f32; space.dim()];
    let mut obs = Vec::new();
    let mut next = Vec::new();
    // A set labelled by an episode cost (docs/SPEC.md, section 13) cuts an unsafe episode where
    // its cost passed the limit: the episode went on, so no transition is terminal, and the
    // cutting step is the one known to have cost 1 (the file keeps no other step's cost).
    let cost_labelled = set.meta().extra.contains_key(defender::EPISODE_COST_LIMIT_KEY);
    for episode in set.episodes() {
        for t in 0..episode.len() {
            obs.clear();
            obs.extend(episode.observation(t).iter().map(|&v| f64::from(v)));
            next.clear();
            next.extend(episode.observation(t + 1).iter().map(|&v| f64::from(v)));
            normalized_action(episode.action(t), space, &mut action);
            let last = t + 1 == episode.len();
            let transition = Transition {
                obs: &obs,
                action: &action,
                reward: f64::from(episode.rew[t]),
                // The crash cost of the three tasks: a crashed demonstration's last step.
                cost: if last && episode.crashed { 1.0 } else { 0.0 },
                next_obs: &next,
                terminated: last && episode.crashed && !cost_labelled,
                truncated: last && (!episode.crashed || cost_labelled),
            };
            agent.store_demonstration(&transition, !episode.crashed)?;
        }
    }
    Ok(())
}

/// A demonstration's recorded action `raw` mapped to [-1, 1], the box the agents act in, as the
/// trainer stores actions.
pub(crate) fn normalized_action(raw: &[f32], space: &defender_rl::BoxSpace, out: &mut [f32]) {
    for ((a, &raw), (&low, &high)) in out.iter_mut().zip(raw).zip(space.low().iter().zip(space.high())) {
        *a = (2.0 * (f64::from(raw) - low) / (high - low) - 1.0) as f32;
    }
}

/// The SHA-256 of a file's bytes, as lower-case hex.
pub fn file_sha256(path: &Path) -> Result<String> {
    use sha2::Digest;
    let mut file =
        defender_io::open_input(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut hasher = sha2::Sha256::new();
    std::io::copy(&mut file, &mut hasher).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Records the training episodes as an episode set (`--record-episodes`), through the
/// trainer's hooks; kept in the checkpoint so that a resumed run records every episode. On a task
/// with a per-step cost the episodes are labelled as demonstrations are (docs/SPEC.md, section
/// 13): an episode whose cost passes the limit is unsafe and kept up to that step, so that the
/// offline screen replays what the filter had to prevent.
pub struct TrainingRecorder {
    set: EpisodeSet,
    recorder: EpisodeRecorder,
    started: bool,
    violation: defender::ViolationTracker,
}

const RECORDED_FILE: &str = "recorded_episodes.npz";

impl TrainingRecorder {
    /// An empty recorder for `env_id`.
    pub fn new(env_id: &str, obs_dim: usize, act_dim: usize, provenance: String) -> Result<Self> {
        let rule = defender::UnsafeRule::from_limit(task_cost_limit(env_id))?;
        let mut meta = Meta {
            env_id: Some(env_id.to_string()),
            obs_dim: Some(obs_dim),
            act_dim: Some(act_dim),
            provenance: Some(provenance),
            ..Meta::default()
        };
        if let defender::UnsafeRule::CostAbove(limit) = rule {
            meta.extra.insert(defender::EPISODE_COST_LIMIT_KEY.into(), limit.into());
        }
        Ok(Self {
            set: EpisodeSet::new(obs_dim, act_dim, meta)?,
            recorder: EpisodeRecorder::new(),
            started: false,
            violation: defender::ViolationTracker::new(rule),
        })
    }

    /// Records one step. `task_cost` is the step's cost to the task: the episode is labelled by
    /// it, as `metrics.csv`'s cost counts, not by `t.cost`, which holds a filtered step's charge
    /// to the learner (`filtered_cost = "violation"`): the filter prevented that violation, so
    /// the episode it ended is recorded safe, as a filtered episode on a crash task is.
    pub fn transition(&mut self, t: &Transition<'_>, env_action: &[f64], task_cost: f64) -> Result<()> {
        if !self.started {
            self.recorder.start(t.obs);
            self.violation.reset();
            self.started = true;
        }
        if !self.violation.violated() {
            self.recorder.step(env_action, t.reward, t.next_obs)?;
        }
        self.violation.step(task_cost, t.terminated);
        Ok(())
    }

    /// Ends the episode; a filtered episode is not a crash (SPEC section 6); on a cost task the
    /// episode is unsafe when its cost passed the limit, whatever ended it.
    pub fn end_episode(&mut self, record: &EpisodeRecord) -> Result<()> {
        self.started = false;
        let crashed = match self.violation.rule() {
            defender::UnsafeRule::Crash => record.outcome() == Outcome::Crashed,
            defender::UnsafeRule::CostAbove(_) => self.violation.violated(),
        };
        self.recorder.finish(&mut self.set, crashed)?;
        Ok(())
    }

    /// Episodes recorded.
    pub fn len(&self) -> usize {
        self.set.len()
    }

    /// Writes the set (atomically).
    pub fn save(&self, path: &Path) -> Result<()> {
        self.set.save(path).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Into a checkpoint directory (nothing while empty).
    pub fn save_checkpoint(&self, dir: &Path) -> Result<()> {
        if self.set.is_empty() { Ok(()) } else { self.save(&dir.join(RECORDED_FILE)) }
    }

    /// From a checkpoint directory (an absent file means no episode had been recorded).
    pub fn load_checkpoint(&mut self, dir: &Path) -> Result<()> {
        let path = dir.join(RECORDED_FILE);
        if path.exists() {
            self.set = EpisodeSet::load(&path)?;
        }
        self.started = false;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds one episode of `costs.len()` steps to `recorder`: step `k` costs the task `costs[k]`,
    /// and the learner is charged `charge` on the last step (a filtered step's charge).
    fn episode(recorder: &mut TrainingRecorder, costs: &[f64], charge: f64, filtered: bool) {
        let (obs, next, action) = ([0.5f64, -0.5], [0.25f64, 0.0], [0.1f32]);
        for (k, &cost) in costs.iter().enumerate() {
            let last = k + 1 == costs.len();
            let charged = if last { charge } else { 0.0 };
            let t = Transition {
                obs: &obs,
                action: &action,
                reward: 1.0,
                cost: cost + charged,
                next_obs: &next,
                terminated: false,
                truncated: last && !filtered,
            };
            recorder.transition(&t, &[0.1], cost).unwrap();
        }
        let record = EpisodeRecord {
            episode: 0,
            total_steps: costs.len() as u64,
            episode_return: costs.len() as f64,
            cost: Some(costs.iter().sum()),
            length: costs.len() as u64,
            terminated: false,
            truncated: !filtered,
            filtered,
            unstable: false,
            wall_seconds: 1.0,
        };
        recorder.end_episode(&record).unwrap();
    }

    #[test]
    fn a_cost_task_records_an_episode_unsafe_up_to_the_step_that_passes_the_limit() {
        let mut recorder = TrainingRecorder::new("SafetyHopperVelocity-v1", 2, 1, "test".into()).unwrap();
        // 30 steps costing 1: the 26th passes 25, so 26 steps are kept, unsafe.
        episode(&mut recorder, &[1.0; 30], 0.0, false);
        // 25 steps costing 1, then 5 free: a cost of 25 does not pass 25: safe, whole.
        let mut at_limit = vec![1.0; 25];
        at_limit.extend([0.0; 5]);
        episode(&mut recorder, &at_limit, 0.0, false);
        // The filter ends an episode at its 10th step, charging the learner 26 for the violation
        // it prevented: the task paid 9, so the episode is safe, as metrics.csv counts it.
        episode(&mut recorder, &[1.0; 10][..], 26.0, true);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("episodes.npz");
        recorder.save(&path).unwrap();
        let set = EpisodeSet::load(&path).unwrap();
        assert_eq!(set.meta().extra[defender::EPISODE_COST_LIMIT_KEY], serde_json::json!(25.0));
        let unsafe_: Vec<usize> = set.unsafe_().map(|e| e.len()).collect();
        let safe: Vec<usize> = set.safe().map(|e| e.len()).collect();
        assert_eq!(unsafe_, [26]);
        assert_eq!(safe, [30, 10]);
    }
}
