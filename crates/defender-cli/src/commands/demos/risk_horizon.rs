//! `defender demos risk-horizon`: how far ahead of a crash Recovery RL's safety critic warns.
//! For each seed and `gamma_risk`, the critic is pretrained as a Recovery RL run pretrains it at
//! its first step (the same agent, built by `recovery_agent::build_recovery`, the same
//! demonstrations stored by `setup::preload`, the same `Recovery::pretrain`), on the even-indexed
//! demonstrations of each group; `Q_risk` is then read along the odd-indexed ones, held out, and
//! each `eps_risk` is applied to it with the run's switch ([`super::risk_measure`]).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use defender::EpisodeSet;
use defender_config::profile::Profile;
use defender_config::run_config::with_profile;
use defender_rl::safety::recovery::Recovery;
use defender_rl::safety::{RecoveryConfig, SafetyConfig};
use defender_rl::{AlgoConfig, BoxSpace, Env};

use super::risk_csv::{self, Row};
use super::risk_measure::{Scored, measure};
use crate::setup;

/// Arguments of `defender demos risk-horizon`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender demos risk-horizon --env Hopper-v5 --out risk-hopper.csv
  defender demos risk-horizon --env InvertedDoublePendulum-v5 --gamma-risk 0.9,0.99 --eps-risk 0.3 --seeds 0,1 --out idp.csv
  defender demos risk-horizon --env Hopper-v5 --in-sample --out in-sample.csv    (the critic a run starts from)

For each seed and --gamma-risk, Recovery RL's safety critic Q_risk is pretrained exactly as a
`defender train --recovery` run pretrains it before its first step (the same agent and seed, its
SAC settings from --profile, --pretrain-steps gradient steps, --pos-fraction of each batch drawn
from the violations), but on the even-indexed demonstrations of each group only (1st, 3rd, ...
safe and unsafe ones in file order). Q_risk(s_t, a_t) is then read along the odd-indexed ones,
held out, and each --eps-risk is applied as the run's switch does (Q_risk > eps_risk).

Steps before the violation count from the violating step (the crash, or on a cost task the step
that passed the episode's cost limit), which is 0; seconds are steps x the task's dt. Columns of
the CSV, per seed, gamma_risk and eps_risk: closed_form_steps = ln(eps)/ln(gamma), where an ideal
critic, gamma^k at k steps before the violation, falls to eps (it fires at every whole k below);
first_lead_*: quartiles over the held-out unsafe demonstrations of the steps (and seconds) before
the violation at which Q_risk first passes eps_risk, among those where it ever does
(never_flagged_share: the others; flagged_from_start_share: those flagged at their first step,
whose lead is then their whole length, a lower bound); held_lead_*: where the unbroken run of
flagged steps that ends at the violation begins (unflagged_at_violation_share: those whose
violating step is not flagged); safe_steps_flagged_share and safe_episodes_flagged_share: false
alarms on the held-out safe demonstrations.

It measures the critic pretrained on demonstrations, offline; not the critic after online
training, nor the recovery policy's success. One pretraining (10,000 steps) takes about 40 s on
one core; each further --eps-risk costs nothing. The same seed gives the same file.")]
pub struct RiskHorizonArgs {
    /// Gymnasium id of the task (see `defender env list`).
    #[arg(long)]
    pub env: String,
    /// Demonstration set (.npz); default: the one shipped for the task.
    #[arg(long)]
    pub demos: Option<PathBuf>,
    /// Safety discounts to pretrain a critic for, each in (0, 1) (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.8,0.9,0.95,0.99")]
    pub gamma_risk: Vec<f64>,
    /// Switch thresholds applied to each critic, each in (0, 1) (comma-separated; they cost no
    /// pretraining).
    #[arg(long, value_delimiter = ',', default_value = "0.3,0.5")]
    pub eps_risk: Vec<f64>,
    /// Seeds of the critics, as a run's seed (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "0")]
    pub seeds: Vec<u64>,
    /// Pretraining gradient steps [default: a run's, 10000] ([safety] pretrain_steps).
    #[arg(long)]
    pub pretrain_steps: Option<u64>,
    /// Share of each batch drawn from the violations, in [0, 1) [default: a run's, 0.3]
    /// ([safety] pos_fraction).
    #[arg(long)]
    pub pos_fraction: Option<f64>,
    /// The profile whose SAC settings (batch, learning rate, layers) the critic takes, as a run
    /// of that profile [default: spec, the baselines' runs].
    #[arg(long, value_enum, default_value = "spec")]
    pub profile: Profile,
    /// Pretrain on every demonstration and measure on the same ones: exactly the critic a run
    /// with that seed starts from, read on its own training data (not held out).
    #[arg(long)]
    pub in_sample: bool,
    /// Where to write the table (CSV; written atomically).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `defender demos risk-horizon`.
pub fn run(args: &RiskHorizonArgs) -> Result<()> {
    let base = RecoveryConfig::default();
    let pretrain_steps = args.pretrain_steps.unwrap_or(base.pretrain_steps);
    if pretrain_steps == 0 {
        bail!("--pretrain-steps 0: the critic would be measured untrained; give at least 1");
    }
    let pos_fraction = args.pos_fraction.unwrap_or(base.pos_fraction);
    if args.gamma_risk.is_empty() || args.eps_risk.is_empty() || args.seeds.is_empty() {
        bail!("--gamma-risk, --eps-risk and --seeds each need at least one value");
    }
    let recovery =
        |gamma_risk, eps_risk| RecoveryConfig { gamma_risk, eps_risk, pretrain_steps, pos_fraction };
    // Each knob checked beside valid others, so that the message names the flag at fault.
    let check =
        |gamma, eps, flag: String| SafetyConfig::Recovery(recovery(gamma, eps)).validate().context(flag);
    check(0.5, 0.5, format!("--pos-fraction {pos_fraction}"))?;
    for &g in &args.gamma_risk {
        check(g, 0.5, format!("--gamma-risk {g}"))?;
    }
    for &e in &args.eps_risk {
        check(0.5, e, format!("--eps-risk {e}"))?;
    }
    crate::run_dir::check_writable(&args.out).context("--out")?;

    let task = defender_mujoco::make(&args.env)?;
    let dt = task.inner().dt();
    let space = task.action_space().clone();
    let (obs_dim, act_dim) = (task.observation_space().dim(), space.dim());
    let path = setup::demos_path(&args.env, args.demos.as_deref())?;
    let sha256 = setup::file_sha256(&path)?;
    let set = EpisodeSet::load(&path)?;
    set.check_env(&args.env, obs_dim, act_dim)?;
    let (train, measured) = split(&set, args.in_sample)?;
    let algo = sac_of_profile(&args.env, args.profile)?;
    let AlgoConfig::Sac(sac) = &algo else { bail!("the profile's algorithm is not SAC") };
    let batch_size = sac.batch_size;

    let mut rows = Vec::new();
    for &seed in &args.seeds {
        for &gamma in &args.gamma_risk {
            let start = Instant::now();
            let config = recovery(gamma, args.eps_risk[0]);
            let mut agent = crate::recovery_agent::build_recovery(&config, &algo, obs_dim, act_dim, seed)?;
            setup::preload(&mut agent, &train, &space)?;
            agent.pretrain()?;
            let scored = score(&mut agent, &measured, &space)?;
            note!(
                "{} seed {seed} gamma_risk {gamma}: {pretrain_steps} pretraining steps in {:.0} s",
                args.env,
                start.elapsed().as_secs_f64()
            );
            for &eps in &args.eps_risk {
                rows.push(Row {
                    env: args.env.clone(),
                    dt,
                    seed,
                    gamma,
                    eps,
                    pretrain_steps,
                    pos_fraction,
                    batch_size,
                    profile: args.profile,
                    in_sample: args.in_sample,
                    train: train.group_sizes(),
                    measured: measured.group_sizes(),
                    horizon: measure(&scored, eps),
                    demos_sha256: sha256.clone(),
                });
            }
        }
    }
    risk_csv::write(&args.out, &rows)?;
    risk_csv::print(&rows);
    say!("{} lines -> {}", rows.len(), args.out.display());
    Ok(())
}

/// The SAC settings a run of `profile` on `env` gets (an empty `[sac]` filled by the profile, as
/// `defender train` resolves a bare run).
fn sac_of_profile(env: &str, profile: Profile) -> Result<AlgoConfig> {
    let mut table = toml::Table::new();
    table.insert("env".into(), env.into());
    table.insert("algo".into(), "sac".into());
    table.insert("profile".into(), profile.name().into());
    table.insert("sac".into(), toml::Table::new().into());
    Ok(with_profile(&table, &table)?.algo_config())
}

/// The demonstrations to pretrain on and those to measure: the even- and odd-indexed ones of
/// each group in file order, or every one twice (`in_sample`).
fn split(set: &EpisodeSet, in_sample: bool) -> Result<(EpisodeSet, EpisodeSet)> {
    let (safe, unsafe_) = set.group_sizes();
    let need = if in_sample { 1 } else { 2 };
    if safe < need || unsafe_ < need {
        bail!(
            "{}: {safe} safe and {unsafe_} unsafe demonstrations; the measure needs at least {need} of \
             each ({})",
            set.source().display(),
            if in_sample {
                "a critic learns from the unsafe ones and false alarms are read on the safe ones"
            } else {
                "half of each group to pretrain on, half held out"
            }
        );
    }
    if in_sample {
        return Ok((set.clone(), set.clone()));
    }
    let (mut seen_safe, mut seen_unsafe) = (0usize, 0usize);
    let (mut even, mut odd) = (Vec::new(), Vec::new());
    for e in set.episodes() {
        let seen = if e.crashed { &mut seen_unsafe } else { &mut seen_safe };
        if *seen % 2 == 0 {
            even.push(e.index)
        } else {
            odd.push(e.index)
        }
        *seen += 1;
    }
    Ok((set.reordered(&even)?, set.reordered(&odd)?))
}

/// `Q_risk(s_t, a_t)` along every demonstration of `set`, actions in [-1, 1] as stored.
fn score(agent: &mut Recovery, set: &EpisodeSet, space: &BoxSpace) -> Result<Vec<Scored>> {
    let mut action = vec![0.0f32; space.dim()];
    let mut obs = Vec::new();
    let mut out = Vec::with_capacity(set.len());
    for e in set.episodes() {
        let mut q = Vec::with_capacity(e.len());
        for t in 0..e.len() {
            obs.clear();
            obs.extend(e.observation(t).iter().map(|&v| f64::from(v)));
            setup::normalized_action(e.action(t), space, &mut action);
            q.push(agent.risk(&obs, &action)?);
        }
        out.push(Scored { q, violation: e.crashed });
    }
    Ok(out)
}
