//! `DefenderEnv` wraps environments: a small line world whose every step is visible, and the real
//! MuJoCo Hopper-v5.

#![allow(clippy::unwrap_used)] // test and bench helpers fail loudly on purpose

use defender::{DefenderConfig, DefenderEnv, EpisodeSet, Meta, Mode};
use defender_rl::{BoxSpace, Env, Outcome, Step, StepInfo, TimeLimit};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A point on a line: the action moves it; |x| > 3 is a crash (terminated). Counts its steps.
#[derive(Debug)]
struct Line {
    obs_space: BoxSpace,
    act_space: BoxSpace,
    x: f64,
    steps: usize,
}

impl Line {
    fn new() -> Self {
        Self {
            obs_space: BoxSpace::unbounded(2),
            act_space: BoxSpace::new(vec![-1.0], vec![1.0]).unwrap(),
            x: 0.0,
            steps: 0,
        }
    }
}

impl Env for Line {
    fn id(&self) -> &str {
        "Line-v0"
    }
    fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }
    fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }
    fn reset(&mut self, _seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.x = 0.0;
        Ok(vec![self.x, 1.0])
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        self.steps += 1;
        self.x += action[0];
        let terminated = self.x.abs() > 3.0;
        Ok(Step {
            obs: vec![self.x, 1.0],
            reward: 1.0,
            terminated,
            truncated: false,
            info: StepInfo::default(),
        })
    }
}

/// Safe demonstrations stay near 0; unsafe ones run to +4 and crash. Rewards: safe 1, unsafe
/// down to -7 (the default R_task).
fn line_demos() -> EpisodeSet {
    let mut set = EpisodeSet::new(2, 1, Meta { env_id: Some("Line-v0".into()), ..Meta::default() }).unwrap();
    for k in 0..3 {
        let xs: Vec<f64> = (0..=10).map(|t| 0.1 * ((t + k) % 3) as f64 - 0.1).collect();
        let obs: Vec<f64> = xs.iter().flat_map(|&x| [x, 1.0]).collect();
        let act: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        set.push_episode_f64(&obs, &act, &[1.0; 10], false).unwrap();
    }
    for k in 0..3 {
        let xs: Vec<f64> = (0..=4).map(|t| t as f64 * (1.0 + 0.05 * k as f64)).collect();
        let obs: Vec<f64> = xs.iter().flat_map(|&x| [x, 1.0]).collect();
        let act: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        set.push_episode_f64(&obs, &act, &[0.0, -1.0, -3.0, -7.0], true).unwrap();
    }
    set
}

fn config(strategy: &str) -> DefenderConfig {
    let mut c = DefenderConfig { strategy: strategy.parse().unwrap(), ..DefenderConfig::default() };
    c.dynamics.buffer_size = 1000;
    c.dynamics.hidden = vec![32, 32];
    c.dynamics.batch_size = 16;
    c
}

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
