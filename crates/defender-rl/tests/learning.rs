//! SAC and TD3 learn Pendulum-v1: a short run beats a random policy (about -1200) by far.

use defender_rl::classic::Pendulum;
use defender_rl::{AlgoConfig, Budget, NoHooks, RunEnd, SacConfig, Td3Config, Trainer, TrainerConfig};

fn final_return(algo: AlgoConfig, steps: u64) -> f64 {
    let agent = algo.build(3, 1, 0).expect("agent");
    let config = TrainerConfig::new(0, Budget::Steps(steps));
    let mut trainer = Trainer::new(agent, Pendulum::new(), Pendulum::new(), config).expect("trainer");
    match trainer.run(&mut NoHooks).expect("run") {
        RunEnd::Complete(eval) => {
            let first: Vec<f64> = trainer.episodes().iter().take(3).map(|e| e.episode_return).collect();
            eprintln!(
                "{:?}: first episodes {first:?}, final eval {:.1} +- {:.1}",
                algo.algo(),
                eval.mean_return,
                eval.std_return
            );
            eval.mean_return
        }
        RunEnd::Stopped => panic!("stopped"),
    }
}

#[test]
fn sac_learns_pendulum() {
    let config = SacConfig { learning_starts: 1000, ..SacConfig::default() };
    let ret = final_return(AlgoConfig::Sac(config), 8_000);
    assert!(ret > -400.0, "SAC final evaluation {ret}");
}

#[test]
fn td3_learns_pendulum() {
    let config = Td3Config { learning_starts: 1000, ..Td3Config::default() };
    let ret = final_return(AlgoConfig::Td3(config), 10_000);
    assert!(ret > -400.0, "TD3 final evaluation {ret}");
}
