//! The number of network threads changes nothing: SAC and TD3 trained with one thread and with
//! two (the actor's products split, the twin critics side by side) are equal bit for bit.

use defender_nn::Parallelism;
use defender_rl::classic::Pendulum;
use defender_rl::{Agent, Budget, Sac, SacConfig, Td3, Td3Config, Trainer, TrainerConfig};

/// Networks wide enough (64) for their products to take the parallel path.
const NET: [usize; 2] = [64, 64];

/// The training episodes' returns and the policy's parameters (as bits) after 700 steps.
fn train<A: Agent>(agent: A, actor: impl Fn(&A) -> &[f32]) -> (Vec<f64>, Vec<u32>) {
    let config = TrainerConfig { final_eval_episodes: 2, ..TrainerConfig::new(3, Budget::Steps(700)) };
    let mut trainer = Trainer::new(agent, Pendulum::new(), Pendulum::new(), config).expect("trainer");
    trainer.run(&mut defender_rl::NoHooks).expect("run");
    let returns = trainer.episodes().iter().map(|e| e.episode_return).collect();
    (returns, actor(trainer.agent()).iter().map(|p| p.to_bits()).collect())
}

#[test]
fn sac_is_bit_identical_on_one_and_two_threads() {
    let config =
        SacConfig { net_arch: NET.to_vec(), batch_size: 64, learning_starts: 100, ..SacConfig::default() };
    let runs: Vec<(Vec<f64>, Vec<u32>)> = [Parallelism::Sequential, Parallelism::threads(2)]
        .into_iter()
        .map(|par| {
            let mut sac = Sac::new(config.clone(), 3, 1, 7).expect("sac");
            sac.set_parallelism(par);
            train(sac, |a| a.actor().params())
        })
        .collect();
    assert!(runs[0].0.len() > 2, "too few episodes to compare");
    assert_eq!(runs[0], runs[1]);
}

#[test]
fn td3_is_bit_identical_on_one_and_two_threads() {
    let config =
        Td3Config { net_arch: NET.to_vec(), batch_size: 64, learning_starts: 100, ..Td3Config::default() };
    let runs: Vec<(Vec<f64>, Vec<u32>)> = [Parallelism::Sequential, Parallelism::threads(2)]
        .into_iter()
        .map(|par| {
            let mut td3 = Td3::new(config.clone(), 3, 1, 7).expect("td3");
            td3.set_parallelism(par);
            train(td3, |a| a.actor().params())
        })
        .collect();
    assert!(runs[0].0.len() > 2, "too few episodes to compare");
    assert_eq!(runs[0], runs[1]);
}
