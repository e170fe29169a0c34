//! What a resumed run must match. A run is one configuration from its first step to its last:
//! `--resume` refuses a flag, a `--config` file or an edited `config.toml` that would change it
//! (a run that trained with two strategies would report only the second), and the checkpoint
//! pins the configuration it was written with. Only the budget may grow, consistently.

use std::io::Write as _;
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

/// Settings whose default changed while runs were in progress, as `(key, the value the former
/// default gave, the current default)`: the dynamics model's schedule, SPEC section 5's until
/// the cheaper default (docs/decisions.md). A run started before keeps its own value (its
/// `config.toml` and pinned configuration hold it explicitly); a request that carries only the
/// current default (as a sweep re-expanding its experiment with today's defaults does) is not a
/// change of that run.
fn changed_defaults() -> Result<Vec<(String, toml::Value, toml::Value)>> {
    let former = pairs(&defender::DynamicsConfig::spec_schedule())?;
    let current = pairs(&defender::DynamicsConfig::default())?;
    Ok(former
        .into_iter()
        .zip(current)
        .filter(|((_, f), (_, c))| f != c)
        .map(|((key, f), (_, c))| (format!("defender.dynamics.{key}"), f, c))
        .collect())
}

/// The settings in which `requested` differs from `saved`, as `key: saved -> requested` lines.
/// When `request` (what a user asks of a saved run, not what a checkpoint pins): a key
/// `requested` leaves out is not a difference (values the run resolved itself, such as `r_task`,
/// are absent from what a user asks for), nor is a changed default (see `changed_defaults`).
pub fn differences<T: serde::Serialize>(saved: &T, requested: &T, request: bool) -> Result<Vec<String>> {
    let saved = pairs(saved)?;
    let requested = pairs(requested)?;
    let changed = changed_defaults()?;
    let former_default = |key: &str, old: Option<&toml::Value>, new: &toml::Value| {
        request && changed.iter().any(|(k, f, c)| k == key && old == Some(f) && new == c)
    };
    let show = |v: Option<&toml::Value>| v.map_or("(unset)".to_string(), ToString::to_string);
    let mut diffs = Vec::new();
    for (key, value) in &requested {
        let old = saved.iter().find(|(k, _)| k == key).map(|(_, v)| v);
        if old != Some(value) && !former_default(key, old, value) {
            diffs.push(format!("{key}: {} -> {}", show(old), show(Some(value))));
        }
    }
    if !request {
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
            // A full or closed stderr must not stop the resume: the warning is dropped then.
            let _ = writeln!(
                std::io::stderr(),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A `[defender.dynamics]` section with `key = value` over SPEC's schedule.
    fn dynamics(key: &str, value: &toml::Value) -> toml::Value {
        let mut d = toml::Value::try_from(defender::DynamicsConfig::spec_schedule()).unwrap();
        d.as_table_mut().unwrap().insert(key.into(), value.clone());
        let mut defender = toml::Table::new();
        defender.insert("dynamics".into(), d);
        let mut root = toml::Table::new();
        root.insert("defender".into(), toml::Value::Table(defender));
        toml::Value::Table(root)
    }

    /// A run started when SPEC's schedule was the default resumes when a request carries today's
    /// default (a sweep re-expanding its experiment), keeping its own schedule; any other value
    /// is refused, and a checkpoint's pinned configuration is compared strictly.
    #[test]
    fn a_run_started_under_the_former_default_schedule_resumes_with_it() {
        let changed = changed_defaults().unwrap();
        assert!(!changed.is_empty(), "the default schedule differs from SPEC's");
        for (key, former, current) in changed {
            let field = key.rsplit('.').next().unwrap();
            let saved = dynamics(field, &former);
            let dir = Path::new("run");
            refuse_changes(dir, &saved, &dynamics(field, &current)).unwrap();
            let other = match &current {
                toml::Value::Integer(v) => toml::Value::Integer(v + 1),
                toml::Value::Float(v) => toml::Value::Float(v * 2.0),
                v => panic!("{key}: unexpected {v}"),
            };
            let err = refuse_changes(dir, &saved, &dynamics(field, &other)).unwrap_err().to_string();
            assert!(err.contains(&key), "{err}");
            let strict = differences(&saved, &dynamics(field, &current), false).unwrap();
            assert_eq!(strict.len(), 1, "{strict:?}");
        }
    }
}
