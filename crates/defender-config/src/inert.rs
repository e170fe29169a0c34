//! Settings that make part of a run do nothing, found before it starts: SAC or TD3 never
//! updates when `learning_starts` is at or beyond the budget (`defender train --steps 2000` with
//! the default 5000), DEFENDER's dynamics model never trains when its own `learning_starts` is,
//! and no periodic evaluation runs when `eval_freq` is beyond the budget. Such a run is legal
//! (a smoke test may want it) but should never pass unnoticed: `defender train` and
//! `defender sweep --list` print one warning per setting, naming the key and the fix.

use defender_rl::{Algo, Budget};

use crate::run_config::RunConfig;

/// One warning per inert setting of `config` (none for a budget in episodes, whose length in
/// steps is not known before the run).
pub fn warnings(config: &RunConfig) -> Vec<String> {
    let Ok(Budget::Steps(budget)) = config.budget() else { return Vec::new() };
    let mut out = Vec::new();
    let (section, starts) = match config.algo {
        Algo::Sac => ("sac", config.sac.clone().unwrap_or_default().learning_starts),
        Algo::Td3 => ("td3", config.td3.clone().unwrap_or_default().learning_starts),
    };
    if starts >= budget {
        out.push(format!(
            "[{section}] learning_starts = {starts} is at or beyond the budget of {budget} steps: the agent never \
             updates (it acts at random throughout; updates.csv stays empty); lower [{section}] learning_starts \
             or raise total_steps (--steps)"
        ));
    }
    if let Some(d) = &config.defender {
        let starts = d.dynamics.learning_starts as u64;
        if starts >= budget {
            out.push(format!(
                "[defender.dynamics] learning_starts = {starts} is at or beyond the budget of {budget} steps: \
                 DEFENDER's dynamics model never trains (filtered steps return an untrained prediction); \
                 lower [defender.dynamics] learning_starts or raise total_steps (--steps)"
            ));
        }
    }
    if config.eval_freq > budget {
        out.push(format!(
            "eval_freq = {} is beyond the budget of {budget} steps: no periodic evaluation runs (only the \
             final one); lower eval_freq (--eval-freq) or set it to 0",
            config.eval_freq
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_config::read_config_str;

    #[test]
    fn each_inert_setting_is_named_once() {
        let config = read_config_str("env = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_steps = 2000\n").unwrap();
        let w = warnings(&config);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("[sac] learning_starts = 5000") && w[0].contains("2000"), "{w:?}");

        let config = read_config_str(
            "env = \"Hopper-v5\"\nalgo = \"td3\"\ntotal_steps = 2000\neval_freq = 5000\n\
             [td3]\nlearning_starts = 100\n[defender]\nstrategy = \"MeanDemoW5/MeanDemoW10\"\n\
             [defender.dynamics]\nlearning_starts = 3000\n",
        )
        .unwrap();
        let w = warnings(&config);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("[defender.dynamics] learning_starts = 3000"), "{w:?}");
        assert!(w[1].starts_with("eval_freq = 5000"), "{w:?}");

        let fine =
            read_config_str("env = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_steps = 20000\neval_freq = 20000\n")
                .unwrap();
        assert!(warnings(&fine).is_empty());
        let episodes = read_config_str("env = \"Hopper-v5\"\nalgo = \"sac\"\ntotal_episodes = 2\n").unwrap();
        assert!(warnings(&episodes).is_empty());
    }
}
