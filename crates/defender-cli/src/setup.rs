//! Building a run from its configuration: the task, DEFENDER around it, the agent, the recorder.
//! Shared by `defender train` and `defender demos collect`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use defender::{DefenderConfig, DefenderEnv, EpisodeRecorder, EpisodeSet, Meta};
use defender_rl::{Agent, AlgoConfig, Env, EpisodeRecord, Outcome, SeedPurpose, Transition, derive_seed};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The `[defender]` section of a run configuration.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DefenderSection {
    /// `SAFE/UNSAFE` (SPEC section 3), or `auto` in a configuration given to `defender train`
    /// (chosen before training; `config.toml` then holds the choice and `selection`).
    pub strategy: defender::selection::StrategyChoice,
    /// `state` or `state-action`.
    #[serde(default)]
    pub mode: defender::Mode,
    /// The reward of a filtered step; resolved (from the demonstrations if not given) and saved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_task: Option<f64>,
    /// Demonstrations per group (`None`: all of the file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub num_demos: Option<usize>,
    /// The demonstration set; `None`: the one shipped for the task.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos: Option<PathBuf>,
    /// SHA-256 of the demonstration file's bytes, pinned when the run starts: a resumed run (or a
    /// configuration given with it) refuses a file whose content differs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demos_sha256: Option<String>,
    /// Options of the alignment cost (SPEC section 2; off by default).
    #[serde(default)]
    pub cost: defender::CostOptions,
    /// The dynamics model (SPEC section 5).
    #[serde(default)]
    pub dynamics: defender::DynamicsConfig,
    /// How `strategy = "auto"` chose the strategy (`[defender.selection]`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<defender_report::StrategySelection>,
}

impl DefenderSection {
    /// A section with defaults for `strategy`.
    pub fn new(strategy: defender::selection::StrategyChoice) -> Self {
        Self {
            strategy,
            mode: defender::Mode::default(),
            r_task: None,
            num_demos: None,
            demos: None,
            demos_sha256: None,
            cost: Default::default(),
            dynamics: Default::default(),
            selection: None,
        }
    }

    /// The method crate's configuration.
    pub fn to_config(&self) -> Result<DefenderConfig> {
        Ok(DefenderConfig {
            strategy: self.strategy.fixed().context("strategy \"auto\" is chosen before the run is built")?,
            mode: self.mode,
            num_demos: self.num_demos,
            r_task: self.r_task,
            cost: self.cost,
            dynamics: self.dynamics.clone(),
        })
    }

    /// Applies the `defender train` flags that configure DEFENDER.
    pub fn apply_flags(&mut self, args: &crate::commands::train::TrainArgs) -> Result<()> {
        if let Some(s) = &args.strategy {
            let choice: defender::selection::StrategyChoice = s.parse().context("--strategy")?;
            // `auto` over a strategy already chosen automatically (a resumed run) keeps the choice.
            if !(choice == defender::selection::StrategyChoice::Auto && self.selection.is_some()) {
                self.strategy = choice;
                self.selection = None;
            }
        }
        if let Some(m) = &args.mode {
            self.mode = m.parse().context("--mode")?;
        }
        if args.r_task.is_some() {
            self.r_task = args.r_task;
        }
        if args.num_demos.is_some() {
            self.num_demos = args.num_demos;
        }
        if args.demos.is_some() {
            self.demos.clone_from(&args.demos);
        }
        if args.dynamics_thread {
            self.dynamics.background = true;
        }
        if args.dynamics_spec_schedule {
            let spec = defender::DynamicsConfig::spec_schedule();
            let d = &mut self.dynamics;
            (d.train_freq, d.gradient_steps, d.batch_size, d.learning_rate) =
                (spec.train_freq, spec.gradient_steps, spec.batch_size, spec.learning_rate);
        }
        Ok(())
    }
}

/// Where the demonstration set shipped for `env_id` lives: `data/demos/<ENV>.npz` in the source
/// tree the binary was built from (or `$DEFENDER_DATA/demos/<ENV>.npz`).
pub fn shipped_demos(env_id: &str) -> PathBuf {
    let data = std::env::var_os("DEFENDER_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data")));
    // Canonical when it exists, so that config.toml records a readable path.
    let data = data.canonicalize().unwrap_or(data);
    data.join("demos").join(format!("{env_id}.npz"))
}

/// A built run: the agent, the training environment (DEFENDER around the task when configured),
/// and the unfiltered evaluation environment.
pub struct Built {
    /// The agent.
    pub agent: Box<dyn Agent>,
    /// The training environment.
    pub env: Box<dyn Env>,
    /// The evaluation environment (never filtered: SPEC section 6).
    pub eval_env: Box<dyn Env>,
    /// DEFENDER's dynamics model, read apart from the training environment (for `dynamics.csv`).
    pub dynamics: Option<defender::DynamicsHandle>,
}

/// Builds the agent and the environments of a run; resolves `R_task` and the demonstration path
/// into `section` so that `config.toml` records what was used.
pub fn build(
    env_id: &str,
    algo: &AlgoConfig,
    seed: u64,
    section: Option<&mut DefenderSection>,
) -> Result<Built> {
    let task = defender_mujoco::make(env_id)?;
    let (obs_dim, act_dim) = (task.observation_space().dim(), task.action_space().dim());
    let eval_env: Box<dyn Env> = Box::new(defender_mujoco::make(env_id)?);
    let agent = algo.build(obs_dim, act_dim, seed)?;
    let Some(section) = section else {
        return Ok(Built { agent, env: Box::new(task), eval_env, dynamics: None });
    };
    let path = section.demos.clone().unwrap_or_else(|| shipped_demos(env_id));
    if !path.exists() && section.demos.is_none() {
        bail!(
            "no demonstrations shipped for {env_id} (looked for {}); give --demos FILE.npz \
             (make one with `defender demos collect --env {env_id} --out FILE.npz`)",
            path.display()
        );
    }
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
    if section.strategy == defender::selection::StrategyChoice::Auto {
        let (strategy, record) =
            crate::commands::select::choose_for_run(&demos, section.mode, section.num_demos, section.cost)?;
        section.strategy = strategy.into();
        section.selection = Some(record);
    }
    let config = section.to_config()?;
    let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, SeedPurpose::Wrapper, 0));
    let wrapped = DefenderEnv::new(task, &demos, config, &mut rng)?;
    section.r_task = Some(wrapped.r_task());
    section.demos = Some(path);
    section.demos_sha256 = Some(sha256);
    if section.num_demos.is_none() {
        section.num_demos = Some(demos.group_sizes().0.min(demos.group_sizes().1));
    }
    let dynamics = Some(wrapped.dynamics_handle());
    Ok(Built { agent, env: Box::new(wrapped), eval_env, dynamics })
}

/// The SHA-256 of a file's bytes, as lower-case hex.
pub fn file_sha256(path: &Path) -> Result<String> {
    use sha2::Digest;
    let mut file = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut hasher = sha2::Sha256::new();
    std::io::copy(&mut file, &mut hasher).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Records the training episodes as an episode set (`--record-episodes`), through the
/// trainer's hooks; kept in the checkpoint so that a resumed run records every episode.
pub struct TrainingRecorder {
    set: EpisodeSet,
    recorder: EpisodeRecorder,
    started: bool,
}

const RECORDED_FILE: &str = "recorded_episodes.npz";

impl TrainingRecorder {
    /// An empty recorder for `env_id`.
    pub fn new(env_id: &str, obs_dim: usize, act_dim: usize, provenance: String) -> Result<Self> {
        let meta = Meta {
            env_id: Some(env_id.to_string()),
            obs_dim: Some(obs_dim),
            act_dim: Some(act_dim),
            provenance: Some(provenance),
            ..Meta::default()
        };
        Ok(Self {
            set: EpisodeSet::new(obs_dim, act_dim, meta)?,
            recorder: EpisodeRecorder::new(),
            started: false,
        })
    }

    /// Records one step.
    pub fn transition(&mut self, t: &Transition<'_>, env_action: &[f64]) -> Result<()> {
        if !self.started {
            self.recorder.start(t.obs);
            self.started = true;
        }
        self.recorder.step(env_action, t.reward, t.next_obs)?;
        Ok(())
    }

    /// Ends the episode; a filtered episode is not a crash (SPEC section 6).
    pub fn end_episode(&mut self, record: &EpisodeRecord) -> Result<()> {
        self.started = false;
        let crashed = record.outcome() == Outcome::Crashed;
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
