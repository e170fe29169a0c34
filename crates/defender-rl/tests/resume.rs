//! Determinism and checkpoint/resume: two runs with one seed are identical, and a run stopped
//! and resumed gives exactly what one never stopped gives.

use std::path::Path;

use defender_rl::classic::Pendulum;
use defender_rl::{
    AlgoConfig, BcForm, Budget, EntCoef, EpisodeRecord, EvalRecord, HookError, Hooks, RunEnd, SacConfig,
    Td3Config, Trainer, TrainerConfig, Transition,
};

/// Small networks and an early start so that updates happen within a few episodes.
fn configs() -> [AlgoConfig; 2] {
    [
        AlgoConfig::Sac(SacConfig {
            net_arch: vec![32, 32],
            batch_size: 32,
            buffer_size: 10_000,
            learning_starts: 150,
            ..SacConfig::default()
        }),
        AlgoConfig::Td3(Td3Config {
            net_arch: vec![32, 32],
            batch_size: 32,
            buffer_size: 10_000,
            learning_starts: 150,
            ..Td3Config::default()
        }),
    ]
}

fn trainer_config(seed: u64) -> TrainerConfig {
    TrainerConfig {
        eval_freq: 300,
        eval_episodes: 2,
        final_eval_episodes: 2,
        ..TrainerConfig::new(seed, Budget::Episodes(6))
    }
}

/// Records what a run reports; stops after `stop_after` episodes; keeps an extra file in the
/// checkpoint (as the DEFENDER wrapper's hook would) and reads it back on resume.
#[derive(Default)]
struct Recorder {
    episodes: Vec<EpisodeRecord>,
    evals: Vec<EvalRecord>,
    stop_after: Option<usize>,
    checkpoints: usize,
    resumed_with: Option<String>,
}

impl Hooks for Recorder {
    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        self.episodes.push(record.clone());
        Ok(())
    }
    fn on_evaluation(&mut self, record: &EvalRecord) -> Result<(), HookError> {
        self.evals.push(record.clone());
        Ok(())
    }
    fn on_checkpoint(&mut self, dir: &Path) -> Result<(), HookError> {
        self.checkpoints += 1;
        std::fs::write(dir.join("extra.txt"), format!("episodes={}", self.episodes.len()))?;
        Ok(())
    }
    fn on_resume(&mut self, dir: &Path) -> Result<(), HookError> {
        self.resumed_with = Some(std::fs::read_to_string(dir.join("extra.txt"))?);
        Ok(())
    }
    fn should_stop(&mut self) -> bool {
        self.stop_after.is_some_and(|n| self.episodes.len() >= n)
    }
}

type PendulumTrainer = Trainer<Box<dyn defender_rl::Agent>, Pendulum, Pendulum>;

fn trainer(algo: &AlgoConfig, seed: u64) -> PendulumTrainer {
    let agent = algo.build(3, 1, seed).expect("agent");
    Trainer::new(agent, Pendulum::new(), Pendulum::new(), trainer_config(seed)).expect("trainer")
}

fn returns(records: &[EpisodeRecord]) -> Vec<(u64, u64, u64)> {
    records.iter().map(|r| (r.episode, r.total_steps, r.episode_return.to_bits())).collect()
}

/// The actor's parameters as bits (the file's JSON header order is not fixed, so compare values).
fn final_params(t: &PendulumTrainer, dir: &Path) -> Vec<u32> {
    let path = dir.join("actor.safetensors");
    t.agent().save_actor(&path).expect("save actor");
    let mlp = defender_nn::Mlp::load_safetensors(&path).expect("read actor");
    mlp.params().iter().map(|p| p.to_bits()).collect()
}

#[test]
fn one_seed_gives_identical_runs_and_another_seed_differs() {
    for algo in configs() {
        let mut a = Recorder::default();
        let mut b = Recorder::default();
        let mut c = Recorder::default();
        trainer(&algo, 7).run(&mut a).unwrap();
        trainer(&algo, 7).run(&mut b).unwrap();
        trainer(&algo, 8).run(&mut c).unwrap();
        assert_eq!(a.episodes.len(), 6);
        assert_eq!(returns(&a.episodes), returns(&b.episodes), "{:?}", algo.algo());
        assert_eq!(
            a.evals.iter().map(|e| e.mean_return).collect::<Vec<_>>(),
            b.evals.iter().map(|e| e.mean_return).collect::<Vec<_>>()
        );
        assert_ne!(returns(&a.episodes), returns(&c.episodes));
        // Periodic evaluations every 300 steps (1200 steps: 4), then the final one.
        assert_eq!(a.evals.len(), 5);
        assert!(a.evals.last().unwrap().is_final && !a.evals[0].is_final);
    }
}

#[test]
fn a_stopped_and_resumed_run_equals_an_uninterrupted_one() {
    for algo in configs() {
        let root = tempfile::tempdir().unwrap();
        let mut whole = Recorder::default();
        let mut t = trainer(&algo, 3);
        let end = t.run(&mut whole).unwrap();
        let whole_actor = final_params(&t, root.path());

        let ckpt = root.path().join("run").join("checkpoint");
        let mut first = Recorder { stop_after: Some(3), ..Recorder::default() };
        let mut t1 = trainer(&algo, 3).with_checkpoint_dir(&ckpt);
        assert_eq!(t1.run(&mut first).unwrap(), RunEnd::Stopped);
        assert_eq!(first.episodes.len(), 3);
        assert!(ckpt.join("trainer.json").exists() && ckpt.join("agent/replay.bin").exists());
        drop(t1);

        // A fresh process: build everything again, then resume.
        let mut second = Recorder::default();
        let mut t2 = trainer(&algo, 3).with_checkpoint_dir(&ckpt);
        t2.resume(&ckpt, &mut second).unwrap();
        assert_eq!(second.resumed_with.as_deref(), Some("episodes=3"));
        let end2 = t2.run(&mut second).unwrap();

        let mut resumed = first.episodes.clone();
        resumed.extend(second.episodes.iter().cloned());
        assert_eq!(returns(&whole.episodes), returns(&resumed), "{:?}", algo.algo());
        let (RunEnd::Complete(e1), RunEnd::Complete(e2)) = (end, end2) else { panic!("not complete") };
        assert_eq!(e1.returns, e2.returns);
        assert_eq!(t2.evaluations().len(), whole.evals.len());
        for (x, y) in t2.evaluations().iter().zip(&whole.evals) {
            assert_eq!((x.total_steps, &x.returns), (y.total_steps, &y.returns));
        }
        assert!(final_params(&t2, root.path()) == whole_actor, "final actors differ");
        assert_eq!(t2.episodes().len(), 6);
    }
}

#[test]
fn resume_refuses_another_configuration() {
    let [sac, td3] = configs();
    let root = tempfile::tempdir().unwrap();
    let ckpt = root.path().join("checkpoint");
    let mut stop = Recorder { stop_after: Some(1), ..Recorder::default() };
    trainer(&sac, 1).with_checkpoint_dir(&ckpt).run(&mut stop).unwrap();
    let err = trainer(&td3, 1).resume(&ckpt, &mut Recorder::default()).unwrap_err();
    assert!(err.to_string().contains("state.json"), "{err}");
    let other = AlgoConfig::Sac(SacConfig {
        batch_size: 64,
        ..SacConfig { net_arch: vec![32, 32], ..SacConfig::default() }
    });
    assert!(trainer(&other, 1).resume(&ckpt, &mut Recorder::default()).is_err());
}

/// The authors' agents: demonstrations in the replay buffer before training (SAC also with their
/// behaviour-cloning term, flagged rows from the safe ones), no warm-up, so that learning starts
/// at once on a buffer that is mostly demonstrations.
fn configs_with_demonstrations() -> [AlgoConfig; 2] {
    [
        AlgoConfig::Sac(SacConfig {
            net_arch: vec![32, 32],
            batch_size: 32,
            buffer_size: 10_000,
            learning_starts: 0,
            warmup: false,
            terminal_on_truncation: true,
            ent_coef: EntCoef::Fixed(0.5),
            demos_in_replay: true,
            bc_weight: 1.0,
            bc_form: BcForm::Authors,
            ..SacConfig::default()
        }),
        AlgoConfig::Td3(Td3Config {
            net_arch: vec![32, 32],
            batch_size: 32,
            buffer_size: 10_000,
            learning_starts: 0,
            warmup: false,
            demos_in_replay: true,
            ..Td3Config::default()
        }),
    ]
}

/// A trainer whose agent holds 60 demonstration transitions (two episodes of 30, the first
/// safe, the second a crash), stored as `defender train` stores them before every session.
fn trainer_with_demonstrations(algo: &AlgoConfig, seed: u64) -> PendulumTrainer {
    let mut agent = algo.build(3, 1, seed).expect("agent");
    for (episode, safe) in [(0, true), (1, false)] {
        for t in 0..30 {
            let phase = f64::from(t) * 0.2 + f64::from(episode);
            let obs = [phase.cos(), phase.sin(), 0.5 - f64::from(episode)];
            let next = [(phase + 0.2).cos(), (phase + 0.2).sin(), 0.5 - f64::from(episode)];
            let action = [(phase.sin() * 0.8) as f32];
            let last = t == 29;
            let transition = Transition {
                obs: &obs,
                action: &action,
                reward: -phase,
                cost: 0.0,
                next_obs: &next,
                terminated: last && !safe,
                truncated: last && safe,
            };
            agent.store_demonstration(&transition, safe).expect("store a demonstration");
        }
    }
    Trainer::new(agent, Pendulum::new(), Pendulum::new(), trainer_config(seed)).expect("trainer")
}

#[test]
fn demonstrations_in_the_buffer_survive_a_checkpoint_and_resume_exactly() {
    for algo in configs_with_demonstrations() {
        let root = tempfile::tempdir().unwrap();
        let mut whole = Recorder::default();
        let mut t = trainer_with_demonstrations(&algo, 5);
        t.run(&mut whole).unwrap();
        let whole_actor = final_params(&t, root.path());

        let ckpt = root.path().join("checkpoint");
        let mut first = Recorder { stop_after: Some(2), ..Recorder::default() };
        let mut t1 = trainer_with_demonstrations(&algo, 5).with_checkpoint_dir(&ckpt);
        assert_eq!(t1.run(&mut first).unwrap(), RunEnd::Stopped);
        drop(t1);
        assert!(ckpt.join("agent/replay.bin").exists());

        // A new process stores the demonstrations again, then the checkpoint's buffer replaces
        // its own: the resumed run must not hold them twice, nor lose their flags.
        let mut second = Recorder::default();
        let mut t2 = trainer_with_demonstrations(&algo, 5).with_checkpoint_dir(&ckpt);
        t2.resume(&ckpt, &mut second).unwrap();
        t2.run(&mut second).unwrap();
        let mut resumed = first.episodes.clone();
        resumed.extend(second.episodes.iter().cloned());
        assert_eq!(returns(&whole.episodes), returns(&resumed), "{:?}", algo.algo());
        assert!(final_params(&t2, root.path()) == whole_actor, "{:?}: final actors differ", algo.algo());

        // A control: the same run without its demonstrations ends elsewhere.
        let mut bare = Recorder::default();
        let mut t3 = trainer(&algo, 5);
        t3.run(&mut bare).unwrap();
        assert!(
            final_params(&t3, root.path()) != whole_actor,
            "{:?}: demonstrations changed nothing",
            algo.algo()
        );
    }
}
