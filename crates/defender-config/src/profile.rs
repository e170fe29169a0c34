//! Profiles: one switch (`profile = "authors"`, `--profile authors`) that sets every setting in
//! which the paper's experiments, as its authors' code ran them, differ from SPEC.md
//! (docs/SPEC.md, "The authors' profile"). A profile only fills keys the configuration leaves
//! out, and the run's `config.toml` holds every setting it gave, so a reader sees each one.

use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};

/// Which defaults a run's configuration starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// SPEC.md: the paper's text, with every point it leaves open fixed.
    #[default]
    Spec,
    /// The authors' code (meowatthemoon/DEFENDER): FastDTW with the L1 distance over the last 20
    /// steps, one element per transition, ties executed; the DEFENDER agent learns from the
    /// demonstrations too (in its replay buffer, SAC with a behaviour-cloning term); SAC without
    /// a random warm-up, a fixed entropy coefficient, every episode end terminal.
    Authors,
    /// The filter that cuts crashes and still learns (docs/results-keeps-learning.md): SPEC's
    /// cost, a decision margin of 0.02 on the costs, the agent's own episodes joining the
    /// demonstrations (50 per group), and the learner also learning from the demonstrations
    /// (every demonstration transition in its replay buffer; SAC with a per-row
    /// behaviour-cloning term of weight 1 on the safe demonstrations' rows).
    KeepsLearning,
}

impl Profile {
    /// The name in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Spec => "spec",
            Profile::Authors => "authors",
            Profile::KeepsLearning => "keeps-learning",
        }
    }

    /// The profile named `name` in a configuration.
    ///
    /// # Errors
    /// An unknown name, listing the known ones.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "spec" => Ok(Profile::Spec),
            "authors" => Ok(Profile::Authors),
            "keeps-learning" => Ok(Profile::KeepsLearning),
            other => bail!("profile = \"{other}\": unknown profile (expected {KNOWN})"),
        }
    }

    /// The DTW cost this profile compares trajectories with (`defender select`, `ablate`): the
    /// authors' for `authors`, SPEC's otherwise (`keeps-learning` changes the filter's decision
    /// and the learner, not the cost).
    pub fn cost_options(self) -> defender::CostOptions {
        match self {
            Profile::Authors => defender::CostOptions::authors(),
            Profile::Spec | Profile::KeepsLearning => defender::CostOptions::default(),
        }
    }

    /// The keys this profile sets for a run of `algo` (`"sac"` or `"td3"`), with or without a
    /// `[defender]` section, as a TOML table.
    pub fn settings(self, algo: &str, defender: bool) -> toml::Table {
        let mut t = toml::Table::new();
        match self {
            Profile::Spec => return t,
            Profile::KeepsLearning => return keeps_learning(algo, defender),
            Profile::Authors => {}
        }
        let mut agent = toml::Table::new();
        // No random warm-up: the stochastic policy acts from step 0 and learning starts once a
        // batch is in the buffer (their SAC and TD3 learn from the first full batch).
        agent.insert("warmup".into(), false.into());
        agent.insert("learning_starts".into(), 0.into());
        // Their memory stores `done = terminated or truncated`: a time-limit cut is terminal.
        agent.insert("terminal_on_truncation".into(), true.into());
        if algo == "sac" {
            // Reward scale 2 with alpha 1 in their loss is alpha 0.5 at reward scale 1.
            agent.insert("ent_coef".into(), 0.5.into());
        }
        if defender {
            agent.insert("demos_in_replay".into(), true.into());
            if algo == "sac" {
                agent.insert("bc_weight".into(), 1.0.into());
                agent.insert("bc_form".into(), "authors".into());
            }
            let cost = toml::Table::try_from(defender::CostOptions::authors()).unwrap_or_default();
            let mut section = toml::Table::new();
            section.insert("cost".into(), cost.into());
            t.insert("defender".into(), section.into());
        }
        t.insert(algo.into(), agent.into());
        t
    }
}

/// The names a configuration may give.
const KNOWN: &str = "\"spec\", \"authors\" or \"keeps-learning\"";

/// `keeps-learning`'s settings: nothing for a bare run (bare SAC is the yardstick), and for a
/// DEFENDER run the configuration that held the bar of docs/results-keeps-learning.md. TD3 gets
/// the same filter and the demonstrations in its buffer (it has no cloning term); that
/// combination is unmeasured.
fn keeps_learning(algo: &str, defender: bool) -> toml::Table {
    let mut t = toml::Table::new();
    if !defender {
        return t;
    }
    let filter = toml::Table::try_from(defender::FilterOptions::keeps_learning()).unwrap_or_default();
    let mut section = toml::Table::new();
    section.insert("filter".into(), filter.into());
    t.insert("defender".into(), section.into());
    t.insert(algo.into(), demos_learner(algo).into());
    t
}

/// The learner half of `keeps-learning` (the keys of the `[sac]` or `[td3]` section): every
/// demonstration transition in the replay buffer and, for SAC, per-row cloning of weight 1 on
/// the safe demonstrations' rows. A DEFENDER run under the profile gets it, and `defender train
/// --learn-from-demos` gives it without the filter (the "demonstrations alone" baseline).
pub fn demos_learner(algo: &str) -> toml::Table {
    let mut agent = toml::Table::new();
    agent.insert("demos_in_replay".into(), true.into());
    if algo == "sac" {
        agent.insert("bc_weight".into(), 1.0.into());
        agent.insert("bc_form".into(), "per-row".into());
    }
    agent
}

/// The profile of a new run whose request names none (`defender train` and its `--config` file,
/// an experiment's runs, `DefenderWrapper`): `keeps-learning`, chosen by the filter variants' runs
/// (docs/decisions.md, "The default filter"). A run's record (`config.toml`) is read with the
/// profile it names, and one that names none was written before profiles existed and ran SPEC's
/// behaviour, so records do not take this default (`RunConfig`'s `profile` defaults to `spec`).
pub const NEW_RUN_DEFAULT: Profile = Profile::KeepsLearning;

/// Gives a new run's request (`given`, what the user wrote) the default profile when it names
/// none.
pub fn default_for_new_run(given: &mut toml::Table) {
    if !given.contains_key("profile") {
        given.insert("profile".into(), NEW_RUN_DEFAULT.name().into());
    }
}

/// Fills the keys of `table` (a run configuration as written) that its profile sets and it
/// leaves out; `given` is what the user gave (a key present there is never replaced).
///
/// # Errors
/// An unknown profile name, or a `profile` that is not a string.
pub fn expand(table: &mut toml::Table, given: &toml::Table) -> Result<()> {
    let profile = match given.get("profile").or_else(|| table.get("profile")) {
        None => return Ok(()),
        Some(toml::Value::String(name)) => Profile::from_name(name)?,
        Some(other) => bail!("profile = {other}: expected {KNOWN}"),
    };
    let algo = table.get("algo").and_then(toml::Value::as_str).unwrap_or("sac").to_string();
    let defender = table.contains_key("defender");
    fill(table, given, &profile.settings(&algo, defender));
    Ok(())
}

/// Inserts every leaf of `settings` absent from `given` into `table` (tables merged).
fn fill(table: &mut toml::Table, given: &toml::Table, settings: &toml::Table) {
    for (key, value) in settings {
        let given_here = given.get(key);
        match value {
            toml::Value::Table(inner) => {
                let empty = toml::Table::new();
                let given_inner = given_here.and_then(toml::Value::as_table).unwrap_or(&empty);
                let entry = table.entry(key.clone()).or_insert_with(|| toml::Table::new().into());
                if let Some(sub) = entry.as_table_mut() {
                    fill(sub, given_inner, inner);
                }
            }
            leaf => {
                if given_here.is_none() {
                    table.insert(key.clone(), leaf.clone());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expanded(text: &str) -> toml::Table {
        let given: toml::Table = toml::from_str(text).unwrap();
        let mut table = given.clone();
        expand(&mut table, &given).unwrap();
        table
    }

    #[test]
    fn the_authors_profile_sets_exactly_its_settings() {
        let t = expanded(
            "profile = \"authors\"\nalgo = \"sac\"\n[defender]\nstrategy = \"MeanBothW5/MeanBothW5\"\n",
        );
        let sac = t["sac"].as_table().unwrap();
        let keys: Vec<&str> = sac.keys().map(String::as_str).collect();
        assert_eq!(
            keys,
            [
                "bc_form",
                "bc_weight",
                "demos_in_replay",
                "ent_coef",
                "learning_starts",
                "terminal_on_truncation",
                "warmup"
            ]
        );
        assert_eq!(sac["ent_coef"].as_float(), Some(0.5));
        let cost = t["defender"]["cost"].as_table().unwrap();
        assert_eq!(cost["dtw"].as_str(), Some("fastdtw"));
        assert_eq!(cost["metric"].as_str(), Some("l1"));
        assert_eq!(cost["trajectory_cap"].as_integer(), Some(20));
        assert_eq!(cost["elements"].as_str(), Some("per-transition"));
        assert_eq!(cost["ties"].as_str(), Some("execute"));
        assert_eq!(cost["radius"].as_integer(), Some(1));
        // A bare run gets the authors' SAC, without demonstrations or cloning (their baselines).
        let bare = expanded("profile = \"authors\"\nalgo = \"sac\"\n");
        assert!(!bare["sac"].as_table().unwrap().contains_key("demos_in_replay"));
        assert!(!bare.contains_key("defender"));
        // TD3: demonstrations in the buffer, no cloning term, no entropy coefficient.
        let td3 =
            expanded("profile = \"authors\"\nalgo = \"td3\"\n[defender]\nstrategy = \"MinBoth/MinBoth\"\n");
        let keys: Vec<&str> = td3["td3"].as_table().unwrap().keys().map(String::as_str).collect();
        assert_eq!(keys, ["demos_in_replay", "learning_starts", "terminal_on_truncation", "warmup"]);
    }

    #[test]
    fn the_keeps_learning_profile_sets_exactly_its_settings() {
        let t = expanded("profile = \"keeps-learning\"\nalgo = \"sac\"\n[defender]\nstrategy = \"auto\"\n");
        let sac = t["sac"].as_table().unwrap();
        let keys: Vec<&str> = sac.keys().map(String::as_str).collect();
        assert_eq!(keys, ["bc_form", "bc_weight", "demos_in_replay"]);
        assert_eq!(sac["bc_form"].as_str(), Some("per-row"));
        assert_eq!(sac["bc_weight"].as_float(), Some(1.0));
        let defender = t["defender"].as_table().unwrap();
        assert!(!defender.contains_key("cost"), "SPEC's cost");
        assert_eq!(defender["filter"]["margin"].as_float(), Some(0.02));
        assert_eq!(defender["filter"]["own_episodes"]["keep"].as_integer(), Some(50));
        assert!(!defender["filter"].as_table().unwrap().contains_key("budget"));
        // Bare SAC stays bare SAC: the yardstick the bar compares with.
        let bare = expanded("profile = \"keeps-learning\"\nalgo = \"sac\"\n");
        assert_eq!(bare.keys().map(String::as_str).collect::<Vec<_>>(), ["algo", "profile"]);
        // TD3: the same filter and the demonstrations in its buffer; it has no cloning term.
        let td3 = expanded(
            "profile = \"keeps-learning\"\nalgo = \"td3\"\n[defender]\nstrategy = \"MinBoth/MinBoth\"\n",
        );
        let keys: Vec<&str> = td3["td3"].as_table().unwrap().keys().map(String::as_str).collect();
        assert_eq!(keys, ["demos_in_replay"]);
        assert_eq!(td3["defender"]["filter"]["margin"].as_float(), Some(0.02));
        // What the configuration gives wins, leaf by leaf.
        let given = expanded(
            "profile = \"keeps-learning\"\nalgo = \"sac\"\n[sac]\nbc_weight = 0.5\n[defender]\nstrategy = \"auto\"\n\
             [defender.filter]\nmargin = 0.0\n[defender.filter.own_episodes]\nkeep = 7\n",
        );
        assert_eq!(given["sac"]["bc_weight"].as_float(), Some(0.5));
        assert_eq!(given["sac"]["bc_form"].as_str(), Some("per-row"));
        assert_eq!(given["defender"]["filter"]["margin"].as_float(), Some(0.0));
        assert_eq!(given["defender"]["filter"]["own_episodes"]["keep"].as_integer(), Some(7));
        // It parses into a run configuration that validates.
        let config = crate::run_config::read_config_str(
            "profile = \"keeps-learning\"\nenv = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_steps = 1000\n\
             [defender]\nstrategy = \"MeanBothW5/MeanBothW5\"\n",
        )
        .unwrap();
        config.validate().unwrap();
        assert_eq!(config.profile, Profile::KeepsLearning);
        assert_eq!(config.defender.unwrap().filter.own_episodes.map(|o| o.keep), Some(50));
    }

    #[test]
    fn given_keys_win_and_spec_changes_nothing() {
        let t = expanded(
            "profile = \"authors\"\nalgo = \"sac\"\n[sac]\nbc_weight = 0.0\ndemos_in_replay = false\n\
             [defender]\nstrategy = \"MinBoth/MinBoth\"\n[defender.cost]\nmetric = \"l2\"\n",
        );
        assert_eq!(t["sac"]["bc_weight"].as_float(), Some(0.0));
        assert_eq!(t["sac"]["demos_in_replay"].as_bool(), Some(false));
        assert_eq!(t["defender"]["cost"]["metric"].as_str(), Some("l2"));
        assert_eq!(t["defender"]["cost"]["dtw"].as_str(), Some("fastdtw"));
        let spec = expanded("profile = \"spec\"\nalgo = \"sac\"\n");
        assert!(!spec.contains_key("sac"));
        let given: toml::Table = toml::from_str("profile = \"paper\"").unwrap();
        let err = expand(&mut given.clone(), &given).unwrap_err().to_string();
        assert!(err.contains("unknown profile") && err.contains("\"keeps-learning\""), "{err}");
    }
}
