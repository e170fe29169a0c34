//! Lagrangian SAC in a trainer: deterministic under a seed, and a run stopped and resumed equals
//! one never stopped bit for bit (networks, the cost critic, the multiplier and its window).

use std::path::Path;

use defender_rl::classic::Pendulum;
use defender_rl::safety::LagrangianConfig;
use defender_rl::safety::lagrangian::LagrangianSac;
use defender_rl::{
    Agent, BoxSpace, Budget, Env, EpisodeRecord, HookError, Hooks, RunEnd, SacConfig, Step, Trainer,
    TrainerConfig, UpdateStats,
};

/// Pendulum where a step near the bottom (`cos theta < -0.5`) costs 1, so that episodes cost
/// more than the limit at first and the multiplier moves.
struct CostlyPendulum(Pendulum);

impl Env for CostlyPendulum {
    fn id(&self) -> &str {
        self.0.id()
    }
    fn observation_space(&self) -> &BoxSpace {
        self.0.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.0.action_space()
    }
    fn max_episode_steps(&self) -> Option<usize> {
        self.0.max_episode_steps()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.0.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let mut step = self.0.step(action)?;
        step.cost = f64::from(u8::from(step.obs[0] < -0.5));
        Ok(step)
    }
}

type LagTrainer = Trainer<LagrangianSac, CostlyPendulum, CostlyPendulum>;

fn trainer(seed: u64) -> LagTrainer {
    let sac = SacConfig {
        net_arch: vec![32, 32],
        batch_size: 32,
        buffer_size: 10_000,
        learning_starts: 150,
        ..SacConfig::default()
    };
    let lag = LagrangianConfig { cost_limit: 5.0, lambda_lr: 0.05, window: 3, ..LagrangianConfig::default() };
    let agent = LagrangianSac::new(sac, lag, 3, 1, seed).expect("agent");
    let config = TrainerConfig {
        eval_freq: 400,
        eval_episodes: 1,
        final_eval_episodes: 1,
        ..TrainerConfig::new(seed, Budget::Episodes(6))
    };
    let env = || CostlyPendulum(Pendulum::new());
    Trainer::new(agent, env(), env(), config).expect("trainer")
}

/// What a run reports, as bits: episodes (return, cost) and every update's statistics.
#[derive(Default)]
struct Recorder {
    episodes: Vec<(u64, u64, u64)>,
    updates: Vec<(u64, u32, u32, u32)>,
    stop_after: Option<usize>,
}

impl Hooks for Recorder {
    fn on_episode_end(&mut self, r: &EpisodeRecord) -> Result<(), HookError> {
        self.episodes.push((r.total_steps, r.episode_return.to_bits(), r.cost.unwrap_or(0.0).to_bits()));
        Ok(())
    }
    fn on_update(&mut self, _total_steps: u64, s: &UpdateStats) {
        let bits = |x: Option<f32>| x.expect("a Lagrangian statistic").to_bits();
        self.updates.push((
            s.n_updates,
            s.actor_loss.expect("an actor loss").to_bits(),
            bits(s.cost_critic_loss),
            bits(s.lagrange_multiplier),
        ));
    }
    fn should_stop(&mut self) -> bool {
        self.stop_after.is_some_and(|n| self.episodes.len() >= n)
    }
}

/// The actor's parameters and lambda, as bits.
fn final_state(t: &LagTrainer, dir: &Path) -> (Vec<u32>, u32) {
    let path = dir.join("actor.safetensors");
    t.agent().save_actor(&path).expect("save actor");
    let mlp = defender_nn::Mlp::load_safetensors(&path).expect("read actor");
    (mlp.params().iter().map(|p| p.to_bits()).collect(), t.agent().lambda().to_bits())
}

#[test]
fn one_seed_gives_identical_runs_and_the_multiplier_moves() {
    let (mut a, mut b, mut c) = (Recorder::default(), Recorder::default(), Recorder::default());
    let mut ta = trainer(7);
    ta.run(&mut a).unwrap();
    trainer(7).run(&mut b).unwrap();
    trainer(8).run(&mut c).unwrap();
    assert_eq!(a.episodes.len(), 6);
    assert_eq!((&a.episodes, &a.updates), (&b.episodes, &b.updates));
    assert_ne!(a.updates, c.updates);
    // Episodes cost more than d = 5 (the pendulum starts low): lambda rose from 0.001.
    let lambda = ta.agent().lambda();
    assert!(lambda > 0.05, "lambda {lambda}, J_c {:?}", ta.agent().mean_episode_cost());
    assert!(a.updates.iter().any(|u| f32::from_bits(u.2) > 0.0), "the cost critic never erred");
}

#[test]
fn a_stopped_and_resumed_run_equals_an_uninterrupted_one() {
    let root = tempfile::tempdir().unwrap();
    let mut whole = Recorder::default();
    let mut t = trainer(3);
    let end = t.run(&mut whole).unwrap();
    let whole_state = final_state(&t, root.path());

    let ckpt = root.path().join("checkpoint");
    let mut first = Recorder { stop_after: Some(3), ..Recorder::default() };
    let mut t1 = trainer(3).with_checkpoint_dir(&ckpt);
    assert_eq!(t1.run(&mut first).unwrap(), RunEnd::Stopped);
    assert!(ckpt.join("agent/lagrangian.json").exists() && ckpt.join("agent/qc_target.safetensors").exists());
    drop(t1);

    let mut second = Recorder::default();
    let mut t2 = trainer(3).with_checkpoint_dir(&ckpt);
    t2.resume(&ckpt, &mut second).unwrap();
    let end2 = t2.run(&mut second).unwrap();
    first.episodes.extend(second.episodes);
    first.updates.extend(second.updates);
    assert_eq!(first.episodes, whole.episodes);
    assert_eq!(first.updates, whole.updates);
    let (RunEnd::Complete(e1), RunEnd::Complete(e2)) = (end, end2) else { panic!("not complete") };
    assert_eq!(e1.returns, e2.returns);
    assert!(final_state(&t2, root.path()) == whole_state, "final actors or multipliers differ");
}

#[test]
fn resume_refuses_a_checkpoint_of_other_settings_or_of_plain_sac() {
    let root = tempfile::tempdir().unwrap();
    let ckpt = root.path().join("checkpoint");
    let mut stop = Recorder { stop_after: Some(1), ..Recorder::default() };
    trainer(1).with_checkpoint_dir(&ckpt).run(&mut stop).unwrap();
    let agent = ckpt.join("agent");
    let sac = SacConfig {
        net_arch: vec![32, 32],
        batch_size: 32,
        buffer_size: 10_000,
        learning_starts: 150,
        ..SacConfig::default()
    };
    let other =
        LagrangianConfig { cost_limit: 4.0, lambda_lr: 0.05, window: 3, ..LagrangianConfig::default() };
    let mut agent2 = LagrangianSac::new(sac.clone(), other, 3, 1, 1).unwrap();
    let err = agent2.load(&agent).unwrap_err().to_string();
    assert!(err.contains("lagrangian.json"), "{err}");
    std::fs::remove_file(agent.join("lagrangian.json")).unwrap();
    let same =
        LagrangianConfig { cost_limit: 5.0, lambda_lr: 0.05, window: 3, ..LagrangianConfig::default() };
    let mut agent3 = LagrangianSac::new(sac, same, 3, 1, 1).unwrap();
    assert!(agent3.load(&agent).is_err(), "a plain SAC checkpoint has no multiplier");
}
