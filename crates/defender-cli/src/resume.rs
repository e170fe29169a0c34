//! What a resumed run must match. A run is one configuration from its first step to its last:
//! `--resume` refuses a flag, a `--config` file or an edited `config.toml` that would change it
//! (a run that trained with two strategies would report only the second), and the checkpoint
//! pins the configuration it was written with. Only the budget may grow, consistently.

use std::path::Path;

use anyhow::{Context, Result, bail};

/// The configuration the checkpoint was written with, beside the trainer's state.
pub const PINNED_CONFIG_FILE: &str = "run_config.toml";

/// Keys that a resumed run may change: the budget (checked against the trainer's own).
const BUDGET_KEYS: [&str; 2] = ["total_steps", "total_episodes"];

/// Flattens a TOML value into `dotted.key = value` pairs.
fn flatten(prefix: &str, value: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
    match value {
        toml::Value::Table(table) => {
            for (k, v) in table {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                flatten(&key, v, out);
            }
        }
        other => out.push((prefix.to_string(), other.clone())),
    }
}

fn pairs<T: serde::Serialize>(config: &T) -> Result<Vec<(String, toml::Value)>> {
    let value = toml::Value::try_from(config).context("cannot serialise the configuration")?;
    let mut out = Vec::new();
    flatten("", &value, &mut out);
    Ok(out.into_iter().filter(|(k, _)| !BUDGET_KEYS.contains(&k.as_str())).collect())
}

/// The settings in which `requested` differs from `saved`, as `key: saved -> requested` lines.
/// A key `requested` leaves out is not a difference when `lenient_missing` (values the run
/// resolved itself, such as `r_task`, are absent from what a user asks for).
pub fn differences<T: serde::Serialize>(
    saved: &T,
    requested: &T,
    lenient_missing: bool,
) -> Result<Vec<String>> {
    let saved = pairs(saved)?;
    let requested = pairs(requested)?;
    let show = |v: Option<&toml::Value>| v.map_or("(unset)".to_string(), ToString::to_string);
    let mut diffs = Vec::new();
    for (key, value) in &requested {
        let old = saved.iter().find(|(k, _)| k == key).map(|(_, v)| v);
        if old != Some(value) {
            diffs.push(format!("{key}: {} -> {}", show(old), show(Some(value))));
        }
    }
    if !lenient_missing {
        for (key, value) in &saved {
            if !requested.iter().any(|(k, _)| k == key) {
                diffs.push(format!("{key}: {} -> (unset)", show(Some(value))));
            }
        }
    }
    Ok(diffs)
}

/// Refuses `requested` (the saved configuration with the command's flags applied) if it changes
/// anything but the budget.
pub fn refuse_changes<T: serde::Serialize>(out: &Path, saved: &T, requested: &T) -> Result<()> {
    let diffs = differences(saved, requested, true)?;
    if !diffs.is_empty() {
        bail!(
            "--resume continues the run in {} with its own configuration; these settings differ from it:\n  {}\n\
             drop those flags (only --steps/--episodes may extend the budget), or train into another --out",
            out.display(),
            diffs.join("\n  ")
        );
    }
    Ok(())
}

/// Refuses a `config.toml` edited since the checkpoint was written.
pub fn check_pinned<T: serde::Serialize + serde::de::DeserializeOwned>(
    checkpoint: &Path,
    saved: &T,
) -> Result<()> {
    let path = checkpoint.join(PINNED_CONFIG_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!(
                "warning: {} has no pinned configuration (an older checkpoint); config.toml is trusted",
                checkpoint.display()
            );
            return Ok(());
        }
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
    };
    let pinned: T =
        toml::from_str(&text).with_context(|| format!("{}: not a run configuration", path.display()))?;
    let diffs = differences(&pinned, saved, false)?;
    if !diffs.is_empty() {
        bail!(
            "config.toml differs from the configuration the checkpoint was trained with ({}):\n  {}\n\
             a run keeps one configuration; restore config.toml, or start a new run in another --out",
            path.display(),
            diffs.join("\n  ")
        );
    }
    Ok(())
}
