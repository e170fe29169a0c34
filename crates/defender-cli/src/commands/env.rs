//! `defender env ...`: the MuJoCo tasks.

use std::io::BufReader;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use defender_mujoco::{Cost, MujocoEnv, Rollout, registry, replay};
use defender_rl::Env;

/// `defender env` subcommands.
#[derive(Debug, Subcommand)]
pub enum EnvCommand {
    /// List the tasks with their observation and action dimensions, horizon and cost rule.
    List,
    /// Replay actions from a given state and write observations, rewards, costs and termination
    /// flags.
    #[command(after_help = REPLAY_HELP)]
    Replay(ReplayArgs),
}

const REPLAY_HELP: &str = "\
The rollout starts from QPOS/QVEL (MuJoCo's data reset, then the state set, as Gymnasium's
set_state after reset) and applies the actions in order until the first terminated step or the
last action; no time limit applies. OUT.npz holds:
  obs         float64 [T'+1, obs_dim]  (row 0 = observation of the given state)
  rew         float64 [T']
  cost        float64 [T']  (only for a task with a cost rule: see `defender env list`)
  terminated  bool    [T']
It is written atomically (a temporary file in the same folder, then renamed).

Example (arrays as numpy writes them: np.save('q.npy', qpos), ...):
  defender env replay --env Hopper-v5 --qpos q.npy --qvel v.npy --actions a.npy --out out.npz
  python -c \"import numpy as np; d = np.load('out.npz'); print(d['obs'].shape, d['rew'].sum())\"";

/// Arguments of `defender env replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Gymnasium id of the task (see `defender env list`).
    #[arg(long, value_name = "ID")]
    env: String,
    /// Initial joint positions: float64 .npy of shape [nq].
    #[arg(long, value_name = "Q.npy")]
    qpos: PathBuf,
    /// Initial joint velocities: float64 .npy of shape [nv].
    #[arg(long, value_name = "V.npy")]
    qvel: PathBuf,
    /// Actions: float64 .npy of shape [T, act_dim].
    #[arg(long, value_name = "A.npy")]
    actions: PathBuf,
    /// Output .npz (obs, rew, cost, terminated).
    #[arg(long, value_name = "OUT.npz")]
    out: PathBuf,
}

/// Runs an `env` subcommand.
///
/// # Errors
/// An unknown task id, an unreadable or malformed input file (the message names the file and
/// what was expected), or a failure to write the output.
pub fn run(cmd: EnvCommand) -> anyhow::Result<()> {
    match cmd {
        EnvCommand::List => {
            put!("{}", list_table());
            Ok(())
        }
        EnvCommand::Replay(args) => run_replay(&args),
    }
}

/// The task registry as an aligned table: `cost` is the rule (`crash`, `velocity > 0.7402`,
/// `none`), `threshold` the velocity threshold alone (`-` for the others), for scripts.
fn list_table() -> String {
    const HEADER: [&str; 6] = ["id", "obs_dim", "act_dim", "horizon", "cost", "threshold"];
    let rows: Vec<[String; 6]> = registry()
        .iter()
        .map(|s| {
            [
                s.id.to_string(),
                s.obs_dim.to_string(),
                s.act_dim.to_string(),
                s.max_episode_steps.to_string(),
                s.cost.to_string(),
                s.cost.threshold().map_or_else(|| "-".to_string(), |t| t.to_string()),
            ]
        })
        .collect();
    let widths: Vec<usize> = (0..HEADER.len())
        .map(|c| rows.iter().map(|r| r[c].len()).chain([HEADER[c].len()]).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    let mut line = |cells: [&str; 6]| {
        // Text left-aligned (id, cost), numbers right-aligned.
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .enumerate()
            .map(
                |(c, (cell, &w))| {
                    if c == 0 || c == 4 { format!("{cell:<w$}") } else { format!("{cell:>w$}") }
                },
            )
            .collect();
        out.push_str(&padded.join("  "));
        out.push('\n');
    };
    line(HEADER);
    for r in &rows {
        line([&r[0], &r[1], &r[2], &r[3], &r[4], &r[5]]);
    }
    out
}

fn run_replay(args: &ReplayArgs) -> anyhow::Result<()> {
    let mut env = MujocoEnv::from_id(&args.env)?;
    let has_cost = env.task().cost() != Cost::None;
    let (nq, nv, act_dim) = (env.qpos().len(), env.qvel().len(), env.action_space().dim());
    let id = env.id().to_owned();
    let qpos = read_f64_npy(&args.qpos, &[Some(nq)], &format!("{id} qpos [nq = {nq}]"))?;
    let qvel = read_f64_npy(&args.qvel, &[Some(nv)], &format!("{id} qvel [nv = {nv}]"))?;
    let actions = read_f64_npy(
        &args.actions,
        &[None, Some(act_dim)],
        &format!("{id} actions [T, act_dim = {act_dim}]"),
    )?;
    let rollout = replay(&mut env, &qpos, &qvel, &actions)
        .with_context(|| format!("replaying {} on {id}", args.actions.display()))?;
    write_rollout(&args.out, &rollout, has_cost)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let end = match (rollout.terminated.last(), rollout.unstable) {
        (_, true) => "terminated (MuJoCo unstable)",
        (Some(true), false) => "terminated",
        _ => "not terminated",
    };
    let cost = if has_cost { format!(", cost {}", rollout.costs.iter().sum::<f64>()) } else { String::new() };
    say!(
        "{id}: {} of {} steps, {end}, return {:.6}{cost} -> {}",
        rollout.steps(),
        actions.len() / act_dim,
        rollout.rewards.iter().sum::<f64>(),
        args.out.display()
    );
    Ok(())
}

/// Reads a float64 C-order .npy whose shape matches `shape` (`None` = any length).
fn read_f64_npy(path: &Path, shape: &[Option<usize>], what: &str) -> anyhow::Result<Vec<f64>> {
    let expected = || {
        let dims: Vec<String> = shape.iter().map(|d| d.map_or("T".into(), |n| n.to_string())).collect();
        format!("a float64 .npy of shape [{}] ({what})", dims.join(", "))
    };
    let file = defender_io::open_input(path)
        .with_context(|| format!("{}: cannot open (expected {})", path.display(), expected()))?;
    let npy = npyz::NpyFile::new(BufReader::new(file))
        .with_context(|| format!("{}: not a readable .npy file (expected {})", path.display(), expected()))?;
    let dtype = npy.dtype();
    let is_f64 = matches!(&dtype, npyz::DType::Plain(ts) if ts.to_string() == "<f8");
    if !is_f64 {
        bail!("{}: dtype {} (expected {})", path.display(), dtype.descr(), expected());
    }
    let got: Vec<u64> = npy.shape().to_vec();
    let fits =
        got.len() == shape.len() && got.iter().zip(shape).all(|(&g, &e)| e.is_none_or(|e| g == e as u64));
    if !fits {
        bail!("{}: shape {:?} (expected {})", path.display(), got, expected());
    }
    if got.len() > 1 && npy.order() == npyz::Order::Fortran {
        bail!("{}: Fortran-ordered array (expected C order: {})", path.display(), expected());
    }
    npy.into_vec::<f64>()
        .with_context(|| format!("{}: reading the data (expected {})", path.display(), expected()))
}

/// Writes obs/rew/cost/terminated to `out` atomically (the project's one `.npz` writer: a
/// temporary file in the same folder, fsync'd, then renamed). `cost` only when the task has a
/// cost rule (`has_cost`): a task without one writes the arrays it always did.
fn write_rollout(out: &Path, rollout: &Rollout, has_cost: bool) -> anyhow::Result<()> {
    use defender::npz::{Data, write_arrays};
    let steps = rollout.steps();
    let (obs_shape, shape) = ([steps + 1, rollout.obs_dim], [steps]);
    let mut arrays = vec![
        ("obs", &obs_shape[..], Data::F64(&rollout.obs)),
        ("rew", &shape[..], Data::F64(&rollout.rewards)),
    ];
    if has_cost {
        arrays.push(("cost", &shape[..], Data::F64(&rollout.costs)));
    }
    arrays.push(("terminated", &shape[..], Data::Bool(&rollout.terminated)));
    write_arrays(out, &arrays)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_is_an_aligned_table_of_the_registry() {
        let table = list_table();
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 1 + registry().len());
        assert!(lines.iter().all(|l| l.len() == lines[0].len()), "{table}");
        assert!(lines[1].starts_with("Hopper-v5") && lines[1].contains(" 1000  crash "), "{table}");
        assert!(table.contains("InvertedDoublePendulum-v5"));
        let hopper = lines.iter().find(|l| l.starts_with("SafetyHopperVelocity-v1")).unwrap();
        assert!(hopper.contains("velocity > 0.7402") && hopper.ends_with("0.7402"), "{table}");
        let cheetah = lines.iter().find(|l| l.starts_with("HalfCheetah-v4")).unwrap();
        assert!(cheetah.contains(" none ") && cheetah.ends_with('-'), "{table}");
    }
}
