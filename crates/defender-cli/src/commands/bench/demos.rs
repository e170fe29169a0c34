//! The demonstrations behind the overhead and dynamics figures: the shipped Hopper-v5 set, a
//! given file, or synthetic Hopper-shaped ones.

use std::path::Path;

use anyhow::{Context, bail};
use defender::synthetic::WalkSet;
use defender::{EpisodeSet, Meta};

use super::{SEED, TASK};

const DEFAULT_DEMOS: &str = "data/demos/Hopper-v5.npz";
/// Demonstrations per group, as in the paper's Hopper experiments.
const DEMOS_PER_GROUP: usize = 50;
/// Added to every observation of the synthetic unsafe demonstrations.
const UNSAFE_OFFSET: f32 = 1000.0;

pub(super) struct DemoSet {
    pub(super) set: EpisodeSet,
    pub(super) label: String,
}

fn synthetic_demos() -> anyhow::Result<DemoSet> {
    // Far from anything Hopper visits: the filter never fires, so every step of a training run
    // pays the environment step, the filter and the dynamics model's training (the upper bound of
    // the overhead). DTW's cost does not depend on values.
    let shape = WalkSet { per_group: DEMOS_PER_GROUP, unsafe_offset: UNSAFE_OFFSET, ..WalkSet::HOPPER };
    let len = shape.len;
    let meta = Meta {
        env_id: Some(TASK.into()),
        provenance: Some("defender bench (synthetic)".into()),
        ..Meta::default()
    };
    let set = shape.build(SEED, meta)?;
    Ok(DemoSet {
        set,
        label: format!(
            "synthetic Hopper-shaped: {DEMOS_PER_GROUP} safe + {DEMOS_PER_GROUP} unsafe smooth random walks of \
             {len} steps, obs 11-D, act 3-D; unsafe ones offset by +{UNSAFE_OFFSET} so the filter never fires \
             (worst case: every step is real)"
        ),
    })
}

fn file_demos(path: &Path) -> anyhow::Result<DemoSet> {
    let set =
        EpisodeSet::load(path).with_context(|| format!("{}: loading demonstrations", path.display()))?;
    set.check_env(TASK, 11, 3).with_context(|| format!("{}: demonstrations for {TASK}", path.display()))?;
    let (safe, unsafe_) = set.group_sizes();
    if safe == 0 || unsafe_ == 0 {
        bail!("{}: {safe} safe and {unsafe_} unsafe demonstrations (both groups are needed)", path.display());
    }
    let n = DEMOS_PER_GROUP.min(safe).min(unsafe_);
    let set = set.select_demos(n)?;
    let lens: Vec<usize> = set.episodes().map(|e| e.len()).collect();
    let mean = lens.iter().sum::<usize>() as f64 / lens.len().max(1) as f64;
    let label = format!(
        "{}: first {n} safe + {n} unsafe of {safe} + {unsafe_}, mean length {mean:.0} steps",
        path.display()
    );
    Ok(DemoSet { set, label })
}

pub(super) fn load_demos(path: Option<&Path>, synthetic: bool) -> anyhow::Result<DemoSet> {
    if synthetic {
        return synthetic_demos();
    }
    if let Some(path) = path {
        return file_demos(path);
    }
    let default = Path::new(DEFAULT_DEMOS);
    if default.exists() {
        match file_demos(default) {
            Ok(d) => return Ok(d),
            Err(err) => note!("warning: {err:#}; using synthetic demonstrations"),
        }
    }
    synthetic_demos()
}
