//! Experiment files (`defender sweep`): the file's syntax and its expansion into checked runs.

/// The task ids a run may name, as `defender` passes them from the simulator's registry
/// (`defender_mujoco::TASKS`, which the fuzz targets do not link).
pub const TASKS: &[&str] = &["Hopper-v5", "Walker2d-v5", "InvertedDoublePendulum-v5"];

/// An experiment file as TOML text: parsed, expanded, every run's configuration checked.
pub fn experiment(data: &[u8]) -> bool {
    let text = String::from_utf8_lossy(data);
    defender_config::experiment::parse(&text, TASKS).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_valid_experiment_is_accepted_and_an_unknown_task_refused() {
        let good = "[grid]\nenvs = [\"Hopper-v5\"]\nseeds = [0]\n[budget]\nsteps = 100\n";
        assert!(experiment(good.as_bytes()));
        assert!(!experiment(good.replace("Hopper", "Hoper").as_bytes()));
    }
}
