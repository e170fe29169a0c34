//! Run configurations (`defender train --config`, `config.toml`) and strategy names.

/// A run configuration as TOML text: parsed with its profile, then validated as `defender train`
/// does before a run starts.
pub fn config(data: &[u8]) -> bool {
    let text = String::from_utf8_lossy(data);
    match defender_config::run_config::read_config_str(&text) {
        Ok(config) => {
            let valid = config.validate().is_ok();
            // What `train` does next with a valid configuration: its warnings, its method config.
            let _ = defender_config::inert::warnings(&config);
            if let Some(section) = &config.defender {
                let _ = section.to_config();
            }
            valid
        }
        Err(_) => false,
    }
}

/// A strategy name (`--strategy`) and a list of them (the ablation's `--strategies`).
pub fn strategy(data: &[u8]) -> bool {
    let text = String::from_utf8_lossy(data);
    let one = text.parse::<defender::Strategy>().is_ok();
    let list = defender::Strategy::parse_list(&text).is_ok();
    let choice = text.parse::<defender::selection::StrategyChoice>().is_ok();
    one || list || choice
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_valid_config_is_accepted_and_a_bad_value_refused() {
        let good = "env = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_steps = 1000\n";
        assert!(config(good.as_bytes()));
        assert!(!config(format!("{good}eval_episodes = 0\n").as_bytes()));
        assert!(strategy(b"MeanDemoW5/MinBoth"));
        assert!(!strategy(b"MeanDemoW5/"));
    }
}
