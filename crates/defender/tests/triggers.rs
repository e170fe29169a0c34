//! The triggers of DEFENDER's end (docs/SPEC.md, section 15) on real MuJoCo with the shipped
//! demonstrations: each ends episodes by the end of SPEC section 5; `dtw` named explicitly is the
//! default filter; and checking interventions against what would have happened leaves the run
//! itself exactly as it was.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

use std::path::PathBuf;

use defender::{
    ClassifierOptions, DefenderConfig, DefenderEnv, EpisodeSet, FilterOptions, OwnEpisodes, TriggerKind,
};
use defender_rl::{Budget, CheckConfig, Env, NoHooks, Outcome, Sac, SacConfig, Trainer, TrainerConfig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn demos() -> EpisodeSet {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/demos/Hopper-v5.npz");
    EpisodeSet::load(path).unwrap()
}

fn hopper(filter: FilterOptions) -> DefenderEnv<Box<dyn Env>> {
    let task: Box<dyn Env> = Box::new(defender_mujoco::make("Hopper-v5").unwrap());
    let config = DefenderConfig { filter, num_demos: Some(10), ..DefenderConfig::default() };
    DefenderEnv::new(task, &demos(), config, &mut ChaCha8Rng::seed_from_u64(0)).unwrap()
}

fn margin(m: f64) -> FilterOptions {
    FilterOptions { trigger: TriggerKind::Margin, task_margin: Some(m), ..FilterOptions::default() }
}

/// A short SAC run on `env`; its episodes and interventions.
fn train(env: DefenderEnv<Box<dyn Env>>, check: CheckConfig) -> (Vec<(f64, u64, Outcome)>, usize, usize) {
    let sac =
        SacConfig { net_arch: vec![32, 32], batch_size: 32, learning_starts: 300, ..SacConfig::default() };
    let agent = Sac::new(sac, 11, 3, 7).unwrap();
    let eval: Box<dyn Env> = Box::new(defender_mujoco::make("Hopper-v5").unwrap());
    let config = TrainerConfig {
        final_eval_episodes: 1,
        counterfactual: check,
        ..TrainerConfig::new(7, Budget::Steps(1200))
    };
    let mut trainer = Trainer::new(agent, env, eval, config).unwrap();
    trainer.run(&mut NoHooks).unwrap();
    let episodes = trainer.episodes().iter().map(|e| (e.episode_return, e.length, e.outcome())).collect();
    let checked = trainer.interventions().iter().filter(|r| r.checked).count();
    (episodes, trainer.interventions().len(), checked)
}

#[test]
fn checking_every_intervention_leaves_the_run_exactly_as_it_was() {
    let (plain, n_plain, checked_plain) = train(hopper(margin(0.3)), CheckConfig::default());
    let every = CheckConfig { every: 1, ..CheckConfig::default() };
    let (checked_run, n, checked) = train(hopper(margin(0.3)), every);
    assert!(n > 5, "the margin trigger ended {n} episodes: too few to compare");
    assert_eq!((n_plain, checked_plain), (n, 0));
    assert_eq!(checked, n, "every intervention was checked");
    assert_eq!(plain, checked_run, "the checked run's episodes differ from the unchecked run's");
}

#[test]
fn the_margin_trigger_ends_an_episode_before_the_task_would_and_its_check_sees_the_fall() {
    let mut env = hopper(margin(0.5));
    let mut ended = 0;
    for episode in 0..5 {
        env.reset(Some(episode)).unwrap();
        loop {
            // Full thrust on every joint tips the hopper over within tens of steps.
            let s = env.step(&[1.0, -1.0, 1.0]).unwrap();
            if s.done() {
                if s.info.filtered {
                    ended += 1;
                    assert!(env.last_score().unwrap() > 0.5, "{:?}", env.last_score());
                    assert_eq!(s.reward, env.r_task());
                }
                break;
            }
        }
    }
    assert!(ended >= 4, "the margin trigger ended {ended} of 5 falling episodes");
    assert_eq!(env.stats().filtered_episodes, ended);
}

#[test]
fn the_classifier_learns_the_demonstrations_and_keeps_learning_from_own_episodes() {
    let options = ClassifierOptions { pretrain_steps: 300, update_steps: 5, ..ClassifierOptions::default() };
    let filter = FilterOptions {
        trigger: TriggerKind::Classifier,
        classifier: Some(options),
        own_episodes: Some(OwnEpisodes { keep: 2 }),
        ..FilterOptions::default()
    };
    let mut env = hopper(filter);
    let mut outcomes = Vec::new();
    for episode in 0..6 {
        env.reset(Some(episode)).unwrap();
        loop {
            let s = env.step(&[0.3, -0.2, 0.1]).unwrap();
            assert!(env.last_score().is_some_and(|p| (0.0..=1.0).contains(&p)));
            if s.done() {
                outcomes.push(env.last_outcome().unwrap());
                break;
            }
        }
    }
    assert!(outcomes.iter().all(|o| *o != Outcome::Truncated), "{outcomes:?}");
    assert!(env.shield().is_some(), "the classifier lends a shield");
}

#[test]
fn dtw_named_is_the_default_and_stays_out_of_a_saved_configuration() {
    let named: FilterOptions = toml::from_str("trigger = \"dtw\"\n").unwrap();
    assert_eq!(named, FilterOptions::default());
    assert!(named.is_spec());
    assert_eq!(toml::to_string(&named).unwrap(), "margin = 0.0\n");
    let mut a = hopper(FilterOptions::default());
    let mut b = hopper(named);
    for env in [&mut a, &mut b] {
        env.reset(Some(3)).unwrap();
    }
    for _ in 0..40 {
        let (sa, sb) = (a.step(&[0.5, 0.5, -0.5]).unwrap(), b.step(&[0.5, 0.5, -0.5]).unwrap());
        assert_eq!(sa, sb);
        assert_eq!(a.last_decision(), b.last_decision());
        if sa.done() {
            break;
        }
    }
}

#[test]
fn triggers_that_cannot_apply_are_refused_naming_the_setting() {
    let task: Box<dyn Env> = Box::new(defender_mujoco::make("Hopper-v5").unwrap());
    let violation = FilterOptions { trigger: TriggerKind::Violation, ..FilterOptions::default() };
    let config = DefenderConfig { filter: violation, num_demos: Some(10), ..DefenderConfig::default() };
    let Err(e) = DefenderEnv::new(task, &demos(), config, &mut ChaCha8Rng::seed_from_u64(0)) else {
        panic!("the violation trigger was accepted on a crash task");
    };
    assert!(e.to_string().contains("violation") && e.to_string().contains("crash task"), "{e}");
    let no_margin = FilterOptions { trigger: TriggerKind::Margin, ..FilterOptions::default() };
    assert!(no_margin.validate().unwrap_err().to_string().contains("task_margin"));
    let stray = FilterOptions { task_margin: Some(0.2), ..FilterOptions::default() };
    assert!(stray.validate().unwrap_err().to_string().contains("task_margin"));
    let mut env = hopper(FilterOptions { trigger: TriggerKind::RiskCritic, ..FilterOptions::default() });
    env.reset(Some(0)).unwrap();
    let e = env.step(&[0.0, 0.0, 0.0]).unwrap_err().to_string();
    assert!(e.contains("risk-critic"), "{e}");
}

/// SAC that remembers the cost of every transition it learns from.
struct CostRecorder {
    sac: Sac,
    costs: Vec<f64>,
}

impl defender_rl::Agent for CostRecorder {
    fn algo(&self) -> &'static str {
        "sac"
    }
    fn obs_dim(&self) -> usize {
        self.sac.obs_dim()
    }
    fn act_dim(&self) -> usize {
        self.sac.act_dim()
    }
    fn num_timesteps(&self) -> u64 {
        self.sac.num_timesteps()
    }
    fn act(
        &mut self,
        obs: &[f64],
        deterministic: bool,
        action: &mut [f32],
    ) -> Result<(), defender_rl::RlError> {
        self.sac.act(obs, deterministic, action)
    }
    fn act_with(
        &mut self,
        obs: &[f64],
        rng: &mut ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), defender_rl::RlError> {
        self.sac.act_with(obs, rng, action)
    }
    fn observe(&mut self, t: &defender_rl::Transition<'_>) -> Result<(), defender_rl::RlError> {
        self.costs.push(t.cost);
        self.sac.observe(t)
    }
    fn store_demonstration(
        &mut self,
        t: &defender_rl::Transition<'_>,
        bc: bool,
    ) -> Result<(), defender_rl::RlError> {
        self.sac.store_demonstration(t, bc)
    }
    fn update(&mut self) -> Result<Option<defender_rl::UpdateStats>, defender_rl::RlError> {
        self.sac.update()
    }
    fn save(&self, dir: &std::path::Path) -> Result<(), defender_rl::RlError> {
        self.sac.save(dir)
    }
    fn load(&mut self, dir: &std::path::Path) -> Result<(), defender_rl::RlError> {
        self.sac.load(dir)
    }
    fn save_actor(&self, path: &std::path::Path) -> Result<(), defender_rl::RlError> {
        self.sac.save_actor(path)
    }
}

#[test]
fn with_the_continuation_charge_a_filtered_step_costs_the_learner_what_its_check_found() {
    for charge in [false, true] {
        let sac = SacConfig {
            net_arch: vec![32, 32],
            batch_size: 32,
            learning_starts: 300,
            ..SacConfig::default()
        };
        let agent = CostRecorder { sac: Sac::new(sac, 11, 3, 7).unwrap(), costs: Vec::new() };
        let eval: Box<dyn Env> = Box::new(defender_mujoco::make("Hopper-v5").unwrap());
        let charge_max = charge.then_some(0.5);
        let check = CheckConfig { every: 1, charge_max, ..CheckConfig::default() };
        let config = TrainerConfig {
            final_eval_episodes: 1,
            counterfactual: check,
            ..TrainerConfig::new(7, Budget::Steps(800))
        };
        let mut trainer = Trainer::new(agent, hopper(margin(0.3)), eval, config).unwrap();
        trainer.run(&mut NoHooks).unwrap();
        let records = trainer.interventions().to_vec();
        assert!(records.iter().filter(|r| r.would_fail == Some(true)).count() > 3, "too few failing checks");
        let costs = &trainer.agent().costs;
        for r in records {
            let learnt = costs[usize::try_from(r.total_steps).unwrap() - 1];
            // A crash costs 1, capped here at 0.5: the cap is what the learner sees.
            let expected = if charge { r.continuation_cost.min(0.5) } else { 0.0 };
            assert_eq!(learnt, expected, "intervention {} (charge {charge})", r.intervention);
        }
    }
}
