//! `DefenderEnv` wraps environments: a small line world whose every step is visible, and the real
//! MuJoCo Hopper-v5.

#![allow(clippy::unwrap_used)] // test and bench helpers fail loudly on purpose

#[path = "common/line.rs"]
mod line;

use defender::{DefenderConfig, DefenderEnv, EpisodeSet, Meta, Mode};
use defender_rl::{Env, Outcome, TimeLimit};
use line::{Line, config, line_demos};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn a_filtered_step_never_reaches_the_environment() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut env =
        DefenderEnv::new(Line::new(), &line_demos(), config("MinBothW5/MinBothW5"), &mut rng).unwrap();
    assert_eq!(env.r_task(), -7.0, "default R_task: the lowest reward of the demonstrations");
    assert_eq!(env.id(), "Line-v0");
    assert!(env.step(&[0.0]).is_err(), "step before reset");
    env.reset(None).unwrap();
    // Staying near 0 is executed.
    for _ in 0..3 {
        let s = env.step(&[0.05]).unwrap();
        assert!(!s.info.filtered && !s.terminated, "{:?}", env.last_decision());
    }
    assert_eq!(env.inner().steps, 3);
    // Running right looks like the unsafe demonstrations: filtered before the crash.
    let mut filtered = None;
    for _ in 0..10 {
        let s = env.step(&[1.0]).unwrap();
        if s.info.filtered {
            filtered = Some(s);
            break;
        }
        assert!(!s.terminated, "crashed before being filtered");
    }
    let s = filtered.expect("the run to the right is filtered");
    assert!(s.terminated && !s.truncated);
    assert_eq!(s.reward, -7.0);
    assert_eq!(s.obs.len(), 2);
    let d = env.last_decision().unwrap();
    assert!(d.filtered && d.safe_cost >= d.unsafe_cost);
    let real = env.inner().steps;
    assert_eq!(real as u64, env.stats().real_steps, "the filtered step did not step the environment");
    assert_eq!(env.stats().steps, env.stats().real_steps + 1);
    assert_eq!(
        env.dynamics().unwrap().real_steps(),
        env.stats().real_steps,
        "the model saw every real transition, only those"
    );
    assert_eq!(env.last_outcome(), Some(Outcome::Filtered));
    assert!(env.step(&[0.0]).is_err(), "the episode is over");
    let st = env.stats();
    assert_eq!((st.episodes, st.filtered_episodes, st.crashed_episodes, st.filtered_steps), (1, 1, 0, 1));
}

#[test]
fn crashes_and_horizons_are_counted() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    // Unsafe demonstrations far to the left: nothing here is filtered.
    let mut demos = EpisodeSet::new(2, 1, Meta::default()).unwrap();
    let far: Vec<f64> = (0..5).flat_map(|t| [-50.0 - t as f64, 1.0]).collect();
    demos.push_episode_f64(&far, &[-1.0; 4], &[-1.0; 4], true).unwrap();
    demos.push_episode_f64(&[0.0, 1.0, 0.0, 1.0], &[0.0], &[1.0], false).unwrap();
    let mut cfg = config("MinBoth/MinBoth");
    cfg.r_task = Some(-100.0);
    let mut env = DefenderEnv::new(TimeLimit::new(Line::new(), 5), &demos, cfg, &mut rng).unwrap();
    assert_eq!(env.r_task(), -100.0);
    assert_eq!(env.max_episode_steps(), Some(5));
    env.reset(Some(3)).unwrap();
    let mut last = None;
    for _ in 0..5 {
        let s = env.step(&[0.0]).unwrap();
        assert!(!s.info.filtered);
        last = Some(s);
    }
    assert!(last.unwrap().truncated);
    assert_eq!(env.last_outcome(), Some(Outcome::Truncated));
    env.reset(None).unwrap();
    let mut steps = 0;
    loop {
        steps += 1;
        let s = env.step(&[1.0]).unwrap();
        if s.done() {
            assert!(s.terminated && !s.info.filtered);
            break;
        }
    }
    assert_eq!(steps, 4);
    assert_eq!(env.last_outcome(), Some(Outcome::Crashed));
    let st = env.stats();
    assert_eq!((st.episodes, st.truncated_episodes, st.crashed_episodes, st.filtered_episodes), (2, 1, 1, 0));
}

#[test]
fn demonstrations_must_fit_the_environment() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut other = EpisodeSet::new(3, 1, Meta::default()).unwrap();
    other.push_episode(&[0.0; 6], &[0.0], &[0.0], false).unwrap();
    other.push_episode(&[0.0; 6], &[0.0], &[0.0], true).unwrap();
    let err =
        DefenderEnv::new(Line::new(), &other, config("MinBoth/MinBoth"), &mut rng).unwrap_err().to_string();
    assert!(err.contains("'obs'") && err.contains("Line-v0"), "{err}");
    let mut cfg = config("MinBoth/MinBoth");
    cfg.num_demos = Some(4);
    let err = DefenderEnv::new(Line::new(), &line_demos(), cfg, &mut rng).unwrap_err().to_string();
    assert!(err.contains("has only 3"), "{err}");
    let mut cfg = config("MinBoth/MinBoth");
    cfg.mode = Mode::StateAction;
    cfg.num_demos = Some(2);
    DefenderEnv::new(Line::new(), &line_demos(), cfg, &mut rng).unwrap();
}

#[test]
fn the_config_saves_as_toml_friendly_names() {
    let cfg = DefenderConfig::default();
    let json = serde_json::to_value(&cfg).unwrap();
    assert_eq!(json["strategy"], "MeanDemoW5/MeanDemoW10");
    assert_eq!(json["mode"], "state");
    let back: DefenderConfig = serde_json::from_value(json).unwrap();
    assert_eq!(back, cfg);
    assert!(serde_json::from_str::<DefenderConfig>(r#"{"strategy": "MinBoth/MinBoth", "typo": 1}"#).is_err());
}

/// Hopper-v5 on MuJoCo: safe demonstrations hold still (zero torques, stopped at 40 steps), unsafe
/// ones are random torques until the hopper falls. A random agent on the wrapped task is filtered
/// before most falls, and filtered steps never reach the simulator.
#[test]
fn wraps_a_real_mujoco_hopper_and_filters() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut hopper = defender_mujoco::make("Hopper-v5").unwrap();
    let act_dim = hopper.action_space().dim();
    let mut demos =
        EpisodeSet::new(11, act_dim, Meta { env_id: Some("Hopper-v5".into()), ..Meta::default() }).unwrap();
    let (mut safe, mut unsafe_) = (0, 0);
    let mut seed = 0;
    while safe < 5 || unsafe_ < 5 {
        seed += 1;
        let random = safe >= 5 || (unsafe_ < 5 && seed % 2 == 0);
        let mut obs = hopper.reset(Some(seed)).unwrap();
        let (mut o, mut a, mut r) = (obs.clone(), Vec::new(), Vec::new());
        let mut crashed = false;
        for _ in 0..200 {
            let act: Vec<f64> =
                (0..act_dim).map(|_| if random { rng.random_range(-1.0..1.0) } else { 0.0 }).collect();
            let s = hopper.step(&act).unwrap();
            a.extend_from_slice(&act);
            r.push(s.reward);
            o.extend_from_slice(&s.obs);
            obs = s.obs;
            if s.terminated {
                crashed = true;
                break;
            }
            if !random && r.len() == 40 {
                break;
            }
        }
        let _ = obs;
        if crashed && unsafe_ < 5 {
            demos.push_episode_f64(&o, &a, &r, true).unwrap();
            unsafe_ += 1;
        } else if !crashed && !random && safe < 5 {
            demos.push_episode_f64(&o, &a, &r, false).unwrap();
            safe += 1;
        }
    }
    let mut cfg =
        DefenderConfig { strategy: "MeanBothW5/MeanBothW5".parse().unwrap(), ..DefenderConfig::default() };
    cfg.dynamics.buffer_size = 10_000;
    let mut env =
        DefenderEnv::new(defender_mujoco::make("Hopper-v5").unwrap(), &demos, cfg, &mut rng).unwrap();
    for ep in 0..10 {
        env.reset(Some(1000 + ep)).unwrap();
        loop {
            let act: Vec<f64> = (0..act_dim).map(|_| rng.random_range(-1.0..1.0)).collect();
            let before = env.inner().elapsed_steps();
            let s = env.step(&act).unwrap();
            if s.info.filtered {
                assert_eq!(env.inner().elapsed_steps(), before, "a filtered step does not step MuJoCo");
                assert!(s.terminated && s.obs.iter().all(|v| v.is_finite()));
            } else {
                assert_eq!(env.inner().elapsed_steps(), before + 1);
            }
            if s.done() {
                break;
            }
        }
    }
    let st = env.stats();
    assert_eq!(st.episodes, 10);
    assert_eq!(st.filtered_episodes + st.crashed_episodes + st.truncated_episodes, 10);
    assert!(st.filtered_episodes >= 1, "some random episodes are filtered: {st:?}");
    assert_eq!(st.filtered_steps, st.filtered_episodes);
    assert_eq!(env.dynamics().unwrap().real_steps(), st.real_steps);
    assert!(env.dynamics().unwrap().prediction_error().count > 0);
}

/// One step's observation, reward, `terminated` and `filtered`.
type StepTrace = (Vec<f64>, f64, bool, bool);

/// Random steps on the line world: every step's result, in order, and the model's final state
/// (a prediction, gradient steps, last loss).
fn line_trace(background: bool, steps: usize) -> (Vec<StepTrace>, Vec<f64>, u64, u32) {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut cfg = config("MeanBothW5/MeanBothW5");
    cfg.dynamics.background = background;
    let mut env = DefenderEnv::new(Line::new(), &line_demos(), cfg, &mut rng).unwrap();
    let mut trace = Vec::new();
    env.reset(None).unwrap();
    for _ in 0..steps {
        let s = env.step(&[rng.random_range(-0.2..0.6)]).unwrap();
        trace.push((s.obs.clone(), s.reward, s.terminated, s.info.filtered));
        if s.done() {
            env.reset(None).unwrap();
        }
    }
    let mut model = env.dynamics().unwrap();
    assert_eq!(model.real_steps(), env.stats().real_steps);
    let probe = model.predict(&[0.5, 1.0], &[0.1]).unwrap();
    (trace, probe, model.gradient_steps(), model.last_loss().to_bits())
}

/// Training the dynamics model on its own thread changes when the work is done, not what it
/// computes: every step (the filtered ones return its predictions) and the final model are
/// bit for bit those of inline training.
#[test]
fn a_background_dynamics_model_equals_the_inline_one() {
    let (inline, background) = (line_trace(false, 400), line_trace(true, 400));
    assert!(inline.0.iter().any(|s| s.3), "some steps are filtered, so predictions are compared");
    assert!(inline.2 > 100, "the model trained: {} gradient steps", inline.2);
    assert_eq!(inline, background);
}

/// A background model is checkpointed once its thread has caught up, and restores into a
/// background environment that goes on exactly as the uninterrupted one.
#[test]
fn a_background_dynamics_model_checkpoints_and_resumes() {
    let run = |stop_at: Option<usize>| {
        let dir = tempfile::tempdir().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut cfg = config("MeanBothW5/MeanBothW5");
        cfg.dynamics.background = true;
        let make =
            |rng: &mut ChaCha8Rng| DefenderEnv::new(Line::new(), &line_demos(), cfg.clone(), rng).unwrap();
        let mut env = make(&mut rng);
        let mut actions = ChaCha8Rng::seed_from_u64(6);
        let mut returns = Vec::new();
        for episode in 0..30 {
            if stop_at == Some(episode) {
                env.save_state(dir.path()).unwrap();
                drop(env);
                env = make(&mut ChaCha8Rng::seed_from_u64(99)); // other weights, then restored
                env.load_state(dir.path()).unwrap();
            }
            env.reset(None).unwrap();
            let mut ret = 0.0;
            loop {
                let s = env.step(&[actions.random_range(-0.2..0.6)]).unwrap();
                ret += s.reward;
                if s.done() {
                    break;
                }
            }
            returns.push(ret.to_bits());
        }
        let probe = env.dynamics().unwrap().predict(&[0.5, 1.0], &[0.1]).unwrap();
        (returns, probe, env.stats())
    };
    assert_eq!(run(None), run(Some(12)));
}

/// What one agent saw and did in a DEFENDER run: every transition it stored (obs, action,
/// reward, terminated, truncated, next obs), every update's statistics, every episode and
/// evaluation, the final policy's actions on probe states, and the DEFENDER counters.
/// A stored transition as bits: obs, action, reward, terminated, truncated, next obs.
type TransitionBits = (Vec<u64>, Vec<u32>, u64, bool, bool, Vec<u64>);

#[derive(Default)]
struct AgentLog {
    transitions: Vec<TransitionBits>,
    updates: Vec<defender_rl::UpdateStats>,
}

impl defender_rl::Hooks for AgentLog {
    fn on_transition(&mut self, t: &defender_rl::Transition<'_>, _env_action: &[f64], _task_cost: f64) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        self.transitions.push((
            bits(t.obs),
            t.action.iter().map(|x| x.to_bits()).collect(),
            t.reward.to_bits(),
            t.terminated,
            t.truncated,
            bits(t.next_obs),
        ));
    }
    fn on_update(&mut self, _total_steps: u64, stats: &defender_rl::UpdateStats) {
        self.updates.push(*stats);
    }
}

struct AgentRun {
    log: AgentLog,
    episodes: Vec<(u64, u64, u64, bool, bool, bool)>,
    evaluations: Vec<u64>,
    policy: Vec<u32>,
    stats: defender::DefenderStats,
    gradient_steps: u64,
    probe: Vec<f64>,
}

/// SAC on the line world under DEFENDER for `steps` steps, the dynamics model trained as `dynamics`.
fn agent_run(dynamics: defender::DynamicsConfig, steps: u64) -> AgentRun {
    use defender_rl::{Agent, AlgoConfig, Budget, SacConfig, Trainer, TrainerConfig};
    let mut cfg = config("MeanBothW5/MeanBothW5");
    cfg.dynamics = dynamics;
    let mut rng = ChaCha8Rng::seed_from_u64(derive_wrapper_seed());
    let env = DefenderEnv::new(TimeLimit::new(Line::new(), 40), &line_demos(), cfg, &mut rng).unwrap();
    let sac =
        SacConfig { net_arch: vec![16, 16], batch_size: 16, learning_starts: 64, ..SacConfig::default() };
    let agent = AlgoConfig::Sac(sac).build(2, 1, 3).unwrap();
    let mut tc = TrainerConfig::new(3, Budget::Steps(steps));
    (tc.eval_freq, tc.eval_episodes, tc.final_eval_episodes) = (100, 2, 2);
    let mut trainer = Trainer::new(agent, env, TimeLimit::new(Line::new(), 40), tc).unwrap();
    let mut log = AgentLog::default();
    trainer.run(&mut log).unwrap();
    let episodes = trainer
        .episodes()
        .iter()
        .map(|r| (r.total_steps, r.episode_return.to_bits(), r.length, r.terminated, r.truncated, r.filtered))
        .collect();
    let evaluations = trainer.evaluations().iter().map(|e| e.mean_return.to_bits()).collect();
    let mut policy = Vec::new();
    for x in [-2.0, -0.5, 0.0, 0.7, 2.5] {
        let mut a = [0.0f32];
        trainer.agent_mut().act(&[x, 1.0], true, &mut a).unwrap();
        policy.push(a[0].to_bits());
    }
    let stats = trainer.env().stats();
    let mut model = trainer.env().dynamics().unwrap();
    let probe = model.predict(&[0.5, 1.0], &[0.1]).unwrap();
    AgentRun { log, episodes, evaluations, policy, stats, gradient_steps: model.gradient_steps(), probe }
}

fn derive_wrapper_seed() -> u64 {
    defender_rl::derive_seed(3, defender_rl::SeedPurpose::Wrapper, 0)
}

/// The agent learns the same whatever the dynamics model's schedule. A filtered step is terminal,
/// so SAC's target never bootstraps from the predicted state (`r + gamma (1 - 1) Q(s', a') = r`),
/// the episode ends there (the filter never sees the prediction), and the model samples with
/// its own RNG. So, bit for bit: every action, reward, flag and observation the agent stores,
/// every update's losses, every episode, evaluation and DEFENDER counter, and the final policy.
/// What differs: the model itself, and therefore the predicted next observation of the filtered
/// (terminal) transitions in the agent's replay buffer, which no update reads.
#[test]
fn the_agent_learns_the_same_whatever_the_dynamics_schedule() {
    let every_step = defender::DynamicsConfig {
        buffer_size: 1000,
        hidden: vec![32, 32],
        batch_size: 16,
        ..Default::default()
    };
    let sparse =
        defender::DynamicsConfig { train_freq: 7, gradient_steps: 2, batch_size: 8, ..every_step.clone() };
    let (a, b) = (agent_run(every_step, 700), agent_run(sparse, 700));
    assert!(a.stats.filtered_steps >= 5, "filtered steps are compared: {:?}", a.stats);
    assert!(a.log.updates.len() > 500, "the agent learnt: {} updates", a.log.updates.len());
    assert_ne!(a.gradient_steps, b.gradient_steps);
    assert_ne!(a.probe, b.probe, "the two models differ");
    assert_eq!(a.stats, b.stats);
    assert_eq!(a.episodes, b.episodes);
    assert_eq!(a.evaluations, b.evaluations);
    assert_eq!(a.policy, b.policy);
    assert_eq!(a.log.updates, b.log.updates);
    assert_eq!(a.log.transitions.len(), b.log.transitions.len());
    let mut differing = 0;
    for (x, y) in a.log.transitions.iter().zip(&b.log.transitions) {
        assert_eq!((&x.0, &x.1, x.2, x.3, x.4), (&y.0, &y.1, y.2, y.3, y.4));
        if x.5 != y.5 {
            assert!(x.3, "only a terminal transition's next observation may differ");
            differing += 1;
        }
    }
    assert!(differing > 0 && differing as u64 <= a.stats.filtered_steps, "{differing} predictions differ");
}
