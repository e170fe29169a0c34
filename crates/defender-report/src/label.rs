//! The algorithm label of a report row: the algorithm and what sets a run apart from its
//! profile's agent and filter (demonstrations, filter options, a `[safety]` baseline), so that
//! the arms of an experiment form rows of their own.

use defender::FilterOptions;
use serde::Deserialize;

use crate::run::RawConfig;

/// What sets an agent apart in a report: the authors' demonstrations in its buffer and cloning.
#[derive(Deserialize, Default)]
pub(crate) struct RawAgent {
    #[serde(default)]
    demos_in_replay: Option<bool>,
    #[serde(default)]
    bc_weight: Option<f64>,
    /// The learner's random warm-up, in training steps.
    #[serde(default)]
    pub(crate) learning_starts: Option<u64>,
}

/// A row's algorithm label as tables and plots print it: the algorithm in capitals, what sets
/// the run apart as written (`SAC (demos+BC, margin0.02+own50)`).
pub fn algo_display(label: &str) -> String {
    match label_parts(label) {
        (algo, Some(tags)) => format!("{} ({tags})", algo.to_uppercase()),
        (algo, None) => algo.to_uppercase(),
    }
}

/// A row's algorithm label (`algo_label`) taken apart: the algorithm (`sac`) and what sets the
/// run apart, if anything (`demos+BC, margin0.02+own50`).
pub(crate) fn label_parts(label: &str) -> (&str, Option<&str>) {
    match label.split_once(" (") {
        Some((algo, tags)) => (algo, Some(tags.strip_suffix(')').unwrap_or(tags))),
        None => (label, None),
    }
}

/// The algorithm as a report row names it: `sac`, or with what sets the run apart from its
/// profile's agent and filter in brackets (`sac (authors)`, `sac (authors, demos+BC)`, `sac
/// (authors, no demos)`, `sac (keeps-learning)`, `sac (demos+BC, margin0.02+own50)`, a peer's
/// `sac (omnisafe-saclag)`), so that the
/// arms of an experiment (docs/experiments.md) form rows of their own, and runs whose filters
/// decide differently never share a row.
pub(crate) fn algo_label(raw: &RawConfig) -> String {
    let profile = raw.profile.as_deref().unwrap_or("spec");
    let agent = raw.sac.as_ref().or(raw.td3.as_ref());
    let demos = agent.and_then(|a| a.demos_in_replay).unwrap_or(false);
    let bc = agent.and_then(|a| a.bc_weight).is_some_and(|w| w > 0.0);
    let mut tags: Vec<String> = Vec::new();
    if profile != "spec" {
        tags.push(profile.to_string());
    }
    // The authors' and keeps-learning profiles give a DEFENDER run the demonstrations; anything
    // else is worth naming.
    let expected = profile != "spec" && raw.defender.is_some();
    match (demos, expected) {
        (true, false) => tags.push(if bc { "demos+BC" } else { "demos" }.into()),
        (false, true) => tags.push("no demos".into()),
        _ => {}
    }
    if let Some(d) = &raw.defender {
        let expected = if profile == "keeps-learning" {
            FilterOptions::keeps_learning()
        } else {
            FilterOptions::default()
        };
        if d.filter != expected {
            tags.push(d.filter.label());
        }
        // A filtered step that charges the learner the violation, or the checked continuation's
        // cost (docs/SPEC.md section 14).
        match d.filtered_cost.as_deref() {
            Some("violation") => tags.push("filtered charged".into()),
            Some("continuation") => tags.push("filtered charged its continuation".into()),
            _ => {}
        }
    }
    if let Some(safety) = &raw.safety {
        tags.push(safety_tag(safety));
    }
    // Another library's run (docs/peers.md) never shares a row with ours.
    if let Some(peer) = &raw.peer {
        tags.push(peer.get("name").and_then(toml::Value::as_str).unwrap_or("peer").to_string());
    }
    if tags.is_empty() { raw.algo.clone() } else { format!("{} ({})", raw.algo, tags.join(", ")) }
}

/// A `[safety]` baseline as a row names it, with its knobs: `penalty 100`, `lagrangian d=0.1`
/// (with ` lr=..` off the default rate, ` norm` with normalised costs, ` clip=..` with gradient
/// clipping), `pid d=25 ki=1e-7`, `recovery eps=0.3 g=0.8`.
fn safety_tag(safety: &toml::Table) -> String {
    let num =
        |key: &str| safety.get(key).and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
    let show = |key: &str| num(key).map_or_else(|| "?".to_string(), |v| format!("{v}"));
    match safety.get("method").and_then(toml::Value::as_str).unwrap_or("?") {
        "penalty" => format!("penalty {}", show("penalty")),
        "lagrangian" => {
            let lr =
                num("lambda_lr").filter(|&lr| lr != 0.01).map_or(String::new(), |lr| format!(" lr={lr}"));
            format!("lagrangian d={}{lr}{}", show("cost_limit"), cost_options(safety))
        }
        "pid" => {
            // The screens tie kp to 10 ki and kd to ki; gains set otherwise are named.
            let default = defender_rl::safety::PidConfig::default();
            let ki = num("ki").unwrap_or(default.ki);
            let (kp, kd) = (num("kp").unwrap_or(default.kp), num("kd").unwrap_or(default.kd));
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-30);
            let gains = if close(kp, 10.0 * ki) && close(kd, ki) {
                String::new()
            } else {
                format!(" kp={kp} kd={kd}")
            };
            format!("pid d={} ki={ki}{gains}{}", show("cost_limit"), cost_options(safety))
        }
        "recovery" => {
            // Pretraining other than the authors' length (10,000 steps) is named.
            let authors = defender_rl::safety::RecoveryConfig::default().pretrain_steps as f64;
            let pretrain = num("pretrain_steps")
                .filter(|&n| n != authors)
                .map_or(String::new(), |n| format!(" pretrain={n}"));
            format!("recovery eps={} g={}{pretrain}", show("eps_risk"), show("gamma_risk"))
        }
        other => other.to_string(),
    }
}

/// The Lagrangian agents' cost options a label shows: ` norm` (normalised costs), ` clip=N`.
fn cost_options(safety: &toml::Table) -> String {
    let mut tags = String::new();
    if safety.get("cost_normalize").and_then(toml::Value::as_bool) == Some(true) {
        tags.push_str(" norm");
    }
    if let Some(n) =
        safety.get("max_grad_norm").and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
    {
        tags.push_str(&format!(" clip={n}"));
    }
    tags
}

#[cfg(test)]
mod tests {
    use super::*;

    fn label(extra: &str) -> String {
        let text = format!(
            "env = \"Hopper-v5\"\nalgo = \"sac\"\nseed = 0\ntotal_steps = 10\ntotal_episodes = 0\n{extra}"
        );
        algo_label(&toml::from_str::<RawConfig>(&text).unwrap())
    }

    #[test]
    fn the_lagrangian_agents_and_a_charged_filter_name_their_knobs() {
        assert_eq!(
            label("[safety]\nmethod = \"lagrangian\"\ncost_limit = 0.2\nlambda_lr = 0.01\n"),
            "sac (lagrangian d=0.2)"
        );
        assert_eq!(
            label(
                "[safety]\nmethod = \"lagrangian\"\ncost_limit = 0.2\nlambda_lr = 0.1\ncost_normalize = true\nmax_grad_norm = 40.0\n"
            ),
            "sac (lagrangian d=0.2 lr=0.1 norm clip=40)"
        );
        assert_eq!(
            label("[safety]\nmethod = \"pid\"\ncost_limit = 25.0\nkp = 0.01\nki = 0.001\nkd = 0.001\n"),
            "sac (pid d=25 ki=0.001)"
        );
        let charged = "[defender]\nstrategy = \"MinBothW5/MinBothW10\"\nmode = \"state\"\nfiltered_cost = \"violation\"\n";
        assert_eq!(label(charged), "sac (filtered charged)");
        let continuation = charged.replace("\"violation\"", "\"continuation\"");
        assert_eq!(label(&continuation), "sac (filtered charged its continuation)");
    }

    #[test]
    fn pid_gains_off_the_screens_ratio_and_recovery_pretraining_off_the_default_are_named() {
        let pid = |gains: &str| label(&format!("[safety]\nmethod = \"pid\"\ncost_limit = 0.2\n{gains}"));
        assert_eq!(pid("kp = 1e-3\nki = 1e-4\nkd = 1e-4\n"), "sac (pid d=0.2 ki=0.0001)");
        assert_eq!(pid("kp = 0.1\nki = 1e-2\nkd = 1e-2\n"), "sac (pid d=0.2 ki=0.01)");
        assert_eq!(pid("kp = 200.0\nki = 1e-2\nkd = 200.0\n"), "sac (pid d=0.2 ki=0.01 kp=200 kd=200)");
        assert_eq!(pid(""), "sac (pid d=0.2 ki=0.0000001)"); // the defaults, tied
        let rec = |extra: &str| {
            label(&format!("[safety]\nmethod = \"recovery\"\neps_risk = 0.5\ngamma_risk = 0.8\n{extra}"))
        };
        assert_eq!(rec(""), "sac (recovery eps=0.5 g=0.8)");
        assert_eq!(rec("pretrain_steps = 10000\n"), "sac (recovery eps=0.5 g=0.8)");
        assert_eq!(rec("pretrain_steps = 50000\n"), "sac (recovery eps=0.5 g=0.8 pretrain=50000)");
    }
}
