//! Recovery RL under the trainer: one seed gives one run, and a run stopped and resumed gives
//! exactly what one never stopped gives, the safety critic, the recovery policy, their buffer
//! and the pretraining state included.

use std::path::Path;

use defender_rl::classic::Pendulum;
use defender_rl::safety::RecoveryConfig;
use defender_rl::safety::recovery::Recovery;
use defender_rl::{
    Agent, Budget, EpisodeRecord, HookError, Hooks, RunEnd, Sac, SacConfig, Trainer, TrainerConfig,
    Transition,
};

const PRETRAIN: u64 = 40;

/// Recovery RL around a small SAC, with three hand-made demonstrations of 20 steps (the last
/// one crashed: its last step costs 1 and terminates).
fn agent(seed: u64) -> Recovery {
    let config = SacConfig {
        net_arch: vec![32, 32],
        batch_size: 32,
        buffer_size: 10_000,
        learning_starts: 150,
        ..SacConfig::default()
    };
    let sac = Sac::new(config, 3, 1, seed).expect("sac");
    let settings = RecoveryConfig {
        gamma_risk: 0.8,
        eps_risk: 0.45,
        pretrain_steps: PRETRAIN,
        ..RecoveryConfig::default()
    };
    let mut agent = Recovery::new(sac, settings, seed).expect("recovery");
    for episode in 0..3 {
        for t in 0..20 {
            let x = f64::from(t) / 20.0;
            let obs = [x.cos(), x.sin(), f64::from(episode) - 1.0];
            let next = [(x + 0.05).cos(), (x + 0.05).sin(), f64::from(episode) - 1.0];
            let crash = episode == 2 && t == 19;
            let transition = Transition {
                obs: &obs,
                action: &[(x - 0.5) as f32],
                reward: -x,
                cost: if crash { 1.0 } else { 0.0 },
                next_obs: &next,
                terminated: crash,
                truncated: t == 19 && !crash,
            };
            agent.store_demonstration(&transition, episode != 2).expect("demonstration");
        }
    }
    agent
}

type RecoveryTrainer = Trainer<Recovery, Pendulum, Pendulum>;

fn trainer(seed: u64) -> RecoveryTrainer {
    let config = TrainerConfig {
        eval_freq: 300,
        eval_episodes: 2,
        final_eval_episodes: 2,
        ..TrainerConfig::new(seed, Budget::Episodes(6))
    };
    Trainer::new(agent(seed), Pendulum::new(), Pendulum::new(), config).expect("trainer")
}

#[derive(Default)]
struct Recorder {
    episodes: Vec<EpisodeRecord>,
    evals: Vec<u64>,
    stop_after: Option<usize>,
}

impl Hooks for Recorder {
    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        self.episodes.push(record.clone());
        Ok(())
    }
    fn on_evaluation(&mut self, record: &defender_rl::EvalRecord) -> Result<(), HookError> {
        self.evals.push(record.mean_return.to_bits());
        Ok(())
    }
    fn should_stop(&mut self) -> bool {
        self.stop_after.is_some_and(|n| self.episodes.len() >= n)
    }
}

fn returns(records: &[EpisodeRecord]) -> Vec<(u64, u64)> {
    records.iter().map(|r| (r.total_steps, r.episode_return.to_bits())).collect()
}

/// What the agent ends with: the task actor's parameters, `Q_risk` on a few probes, the
/// recovery policy's count and the safety critic's gradient steps.
fn fingerprint(t: &mut RecoveryTrainer, dir: &Path) -> (Vec<u32>, Vec<u32>, u64, u64) {
    let path = dir.join("actor.safetensors");
    t.agent().save_actor(&path).expect("save actor");
    let actor = defender_nn::Mlp::load_safetensors(&path).expect("read actor");
    let agent = t.agent_mut();
    let probes = [(-1.0f32, [1.0, 0.0, 0.0]), (0.0, [0.0, 1.0, 2.0]), (0.7, [-1.0, 0.0, -3.0])];
    let risks = probes.iter().map(|(a, obs)| agent.risk(obs, &[*a]).expect("risk").to_bits()).collect();
    (
        actor.params().iter().map(|p| p.to_bits()).collect(),
        risks,
        agent.recovery_steps(),
        agent.risk_updates(),
    )
}

#[test]
fn one_seed_gives_one_run_and_another_seed_another() {
    let root = tempfile::tempdir().unwrap();
    let (mut a, mut b, mut c) = (Recorder::default(), Recorder::default(), Recorder::default());
    let mut ta = trainer(7);
    ta.run(&mut a).unwrap();
    let mut tb = trainer(7);
    tb.run(&mut b).unwrap();
    trainer(8).run(&mut c).unwrap();
    assert_eq!(returns(&a.episodes), returns(&b.episodes));
    assert_eq!(a.evals, b.evals);
    assert_ne!(returns(&a.episodes), returns(&c.episodes));
    let fa = fingerprint(&mut ta, root.path());
    assert_eq!(fa, fingerprint(&mut tb, root.path()));
    let steps = ta.total_steps();
    assert!(fa.2 > 0 && fa.2 < steps, "the recovery policy acted in {} of {steps} steps", fa.2);
}

#[test]
fn a_stopped_and_resumed_run_equals_an_uninterrupted_one() {
    let root = tempfile::tempdir().unwrap();
    let mut whole = Recorder::default();
    let mut t = trainer(3);
    let end = t.run(&mut whole).unwrap();
    let whole_agent = fingerprint(&mut t, root.path());

    let ckpt = root.path().join("run").join("checkpoint");
    let mut first = Recorder { stop_after: Some(3), ..Recorder::default() };
    let mut t1 = trainer(3).with_checkpoint_dir(&ckpt);
    assert_eq!(t1.run(&mut first).unwrap(), RunEnd::Stopped);
    let before = fingerprint(&mut t1, root.path());
    assert!(before.3 >= PRETRAIN, "pretrained before the checkpoint");
    assert!(
        ckpt.join("agent/recovery/state.json").exists() && ckpt.join("agent/recovery/replay.bin").exists()
    );
    drop(t1);

    // A fresh process: the agent built again (demonstrations stored, not pretrained), resumed.
    let mut second = Recorder::default();
    let mut t2 = trainer(3).with_checkpoint_dir(&ckpt);
    t2.resume(&ckpt, &mut second).unwrap();
    assert!(t2.agent().pretrained(), "the pretraining state is restored, not run again");
    assert_eq!(t2.agent().risk_updates(), before.3);
    let end2 = t2.run(&mut second).unwrap();

    let mut resumed = first.episodes.clone();
    resumed.extend(second.episodes.iter().cloned());
    assert_eq!(returns(&resumed), returns(&whole.episodes));
    assert_eq!(end, end2);
    assert_eq!(fingerprint(&mut t2, root.path()), whole_agent);
}
