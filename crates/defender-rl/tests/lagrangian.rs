//! Lagrangian and PID Lagrangian SAC in a trainer: deterministic under a seed, and a run stopped
//! and resumed equals one never stopped bit for bit (networks, the cost critic, the multiplier or
//! the PID controller and their window, the cost normaliser).
#![allow(clippy::unwrap_used)]

use std::path::Path;

use defender_rl::classic::Pendulum;
use defender_rl::safety::lagrangian::LagrangianSac;
use defender_rl::safety::{LagrangianConfig, PidConfig};
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

fn small_sac() -> SacConfig {
    SacConfig {
        net_arch: vec![32, 32],
        batch_size: 32,
        buffer_size: 10_000,
        learning_starts: 150,
        ..SacConfig::default()
    }
}

fn lagrangian() -> LagrangianConfig {
    LagrangianConfig { cost_limit: 5.0, lambda_lr: 0.05, window: 3, ..LagrangianConfig::default() }
}

/// The agents under test: the repaired Lagrangian, the same with OmniSafe's options (normalised
/// costs, clipped gradients), and PID with gains large enough to move within six episodes.
#[derive(Clone, Copy, Debug)]
enum Variant {
    Lagrangian,
    OmniSafeOptions,
    Pid,
}

fn agent(variant: Variant, seed: u64) -> LagrangianSac {
    match variant {
        Variant::Lagrangian => LagrangianSac::new(small_sac(), lagrangian(), 3, 1, seed),
        Variant::OmniSafeOptions => {
            let lag = LagrangianConfig { cost_normalize: true, max_grad_norm: Some(40.0), ..lagrangian() };
            LagrangianSac::new(small_sac(), lag, 3, 1, seed)
        }
        Variant::Pid => {
            let pid = PidConfig {
                cost_limit: 5.0,
                kp: 1e-3,
                ki: 1e-4,
                kd: 1e-3,
                window: 3,
                ..PidConfig::default()
            };
            LagrangianSac::pid(small_sac(), pid, 3, 1, seed)
        }
    }
    .expect("agent")
}

fn trainer(seed: u64) -> LagTrainer {
    trainer_of(Variant::Lagrangian, seed)
}

fn trainer_of(variant: Variant, seed: u64) -> LagTrainer {
    let agent = agent(variant, seed);
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
    updates: Vec<(u64, u32, u32, u32, u32)>,
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
            bits(s.qc_mean),
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
    for variant in [Variant::Lagrangian, Variant::OmniSafeOptions, Variant::Pid] {
        stopped_and_resumed(variant);
    }
}

fn stopped_and_resumed(variant: Variant) {
    let root = tempfile::tempdir().unwrap();
    let mut whole = Recorder::default();
    let mut t = trainer_of(variant, 3);
    let end = t.run(&mut whole).unwrap();
    let whole_state = final_state(&t, root.path());

    let ckpt = root.path().join("checkpoint");
    let mut first = Recorder { stop_after: Some(3), ..Recorder::default() };
    let mut t1 = trainer_of(variant, 3).with_checkpoint_dir(&ckpt);
    assert_eq!(t1.run(&mut first).unwrap(), RunEnd::Stopped);
    assert!(ckpt.join("agent/lagrangian.json").exists() && ckpt.join("agent/qc_target.safetensors").exists());
    drop(t1);

    let mut second = Recorder::default();
    let mut t2 = trainer_of(variant, 3).with_checkpoint_dir(&ckpt);
    t2.resume(&ckpt, &mut second).unwrap();
    let end2 = t2.run(&mut second).unwrap();
    first.episodes.extend(second.episodes);
    first.updates.extend(second.updates);
    assert_eq!(first.episodes, whole.episodes, "{variant:?}");
    assert_eq!(first.updates, whole.updates, "{variant:?}");
    let (RunEnd::Complete(e1), RunEnd::Complete(e2)) = (end, end2) else { panic!("not complete") };
    assert_eq!(e1.returns, e2.returns);
    assert!(final_state(&t2, root.path()) == whole_state, "{variant:?}: final actors or multipliers differ");
}

#[test]
fn pid_and_omnisafes_options_learn_and_the_cost_critic_stays_in_bounds() {
    for variant in [Variant::OmniSafeOptions, Variant::Pid] {
        let mut rec = Recorder::default();
        let mut t = trainer_of(variant, 5);
        t.run(&mut rec).unwrap();
        // The pendulum starts low: its episodes cost more than d = 5, so either controller raises
        // lambda (PID's starts at 0, its integral at 0.001).
        let lambda = t.agent().lambda();
        assert!(lambda > 0.001, "{variant:?}: lambda {lambda}");
        // Costs normalised to +-5: Q_c within +-500; raw costs in [0, 1]: within [0, 100].
        let bound = match variant {
            Variant::OmniSafeOptions => (-500.0, 500.0),
            _ => (0.0, 100.0),
        };
        for u in &rec.updates {
            let qc = f32::from_bits(u.4);
            assert!(qc >= bound.0 && qc <= bound.1, "{variant:?}: qc_mean {qc}");
        }
    }
    // The repaired Lagrangian's mean Q_c is that of costs in [0, 1].
    let mut rec = Recorder::default();
    trainer(5).run(&mut rec).unwrap();
    assert!(rec.updates.iter().all(|u| (0.0..=100.0).contains(&f32::from_bits(u.4))));
}

#[test]
fn demonstration_costs_train_the_critic_but_stay_out_of_j_c() {
    use defender_rl::Transition;
    for variant in [Variant::Lagrangian, Variant::Pid] {
        let mut a = agent(variant, 2);
        let (obs, next, act) = ([0.1, 0.2, 0.3], [0.2, 0.3, 0.4], [0.5f32]);
        let step = |cost, end| Transition {
            obs: &obs,
            action: &act,
            reward: 0.0,
            cost,
            next_obs: &next,
            terminated: end,
            truncated: false,
        };
        // A costly demonstration episode ending.
        for t in 0..4 {
            a.store_demonstration(&step(1.0, t == 3), false).unwrap();
        }
        assert_eq!(a.mean_episode_cost(), None, "{variant:?}: a demonstration is not a training episode");
        // A training episode of cost 0.5 + 0 is the only one J_c counts.
        a.observe(&step(0.5, false)).unwrap();
        a.observe(&step(0.0, true)).unwrap();
        assert_eq!(a.mean_episode_cost(), Some(0.5), "{variant:?}");
        // A step cost above cost_max (1) is refused, naming the key.
        let err = a.observe(&step(2.0, false)).unwrap_err().to_string();
        assert!(err.contains("cost_max"), "{err}");
        assert!(a.observe(&step(-0.1, false)).is_err(), "a negative cost is refused");
    }
}

#[test]
fn resume_refuses_a_checkpoint_of_other_settings_or_of_plain_sac() {
    let root = tempfile::tempdir().unwrap();
    let ckpt = root.path().join("checkpoint");
    let mut stop = Recorder { stop_after: Some(1), ..Recorder::default() };
    trainer(1).with_checkpoint_dir(&ckpt).run(&mut stop).unwrap();
    let agent = ckpt.join("agent");
    let sac = small_sac();
    let other = LagrangianConfig { cost_limit: 4.0, ..lagrangian() };
    let mut agent2 = LagrangianSac::new(sac.clone(), other, 3, 1, 1).unwrap();
    let err = agent2.load(&agent).unwrap_err().to_string();
    assert!(err.contains("lagrangian.json"), "{err}");
    std::fs::remove_file(agent.join("lagrangian.json")).unwrap();
    let mut agent3 = LagrangianSac::new(sac.clone(), lagrangian(), 3, 1, 1).unwrap();
    assert!(agent3.load(&agent).is_err(), "a plain SAC checkpoint has no multiplier");
    // A PID agent refuses a Lagrangian checkpoint.
    let ckpt = root.path().join("checkpoint2");
    trainer(1)
        .with_checkpoint_dir(&ckpt)
        .run(&mut Recorder { stop_after: Some(1), ..Recorder::default() })
        .unwrap();
    let err = self::agent(Variant::Pid, 1).load(&ckpt.join("agent")).unwrap_err().to_string();
    assert!(err.contains("lagrangian.json"), "{err}");
}
