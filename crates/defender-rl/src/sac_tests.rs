//! SAC's actor gradient, log-probabilities and warm-up.

use super::*;

/// A small agent with a filled buffer and a sampled batch.
fn small(alpha: f32) -> Sac {
    small_with(SacConfig { ent_coef: EntCoef::Fixed(alpha), ..SacConfig::default() })
}

/// As [`small`] with `config`'s algorithm settings; every third transition is a safe
/// demonstration's.
fn small_with(config: SacConfig) -> Sac {
    let config =
        SacConfig { net_arch: vec![16, 16], batch_size: 8, buffer_size: 100, learning_starts: 0, ..config };
    let mut sac = Sac::new(config, 3, 2, 5).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for k in 0..40 {
        let obs: Vec<f64> = (0..3).map(|_| rng.random_range(-1.0..1.0)).collect();
        let next: Vec<f64> = (0..3).map(|_| rng.random_range(-1.0..1.0)).collect();
        let act: Vec<f32> = (0..2).map(|_| rng.random_range(-1.0..1.0)).collect();
        let t = Transition {
            obs: &obs,
            action: &act,
            reward: rng.random_range(-1.0..1.0),
            cost: 0.0,
            next_obs: &next,
            terminated: false,
            truncated: false,
        };
        if k % 3 == 0 {
            sac.store_demonstration(&t, true).unwrap();
        } else {
            sac.observe(&t).unwrap();
        }
    }
    sac.experience.buffer.sample_into(&mut sac.rng, &mut sac.ws.batch).unwrap();
    sac
}

/// The actor loss for the agent's current parameters, with the noise drawn from `rng`.
fn loss(sac: &mut Sac, rng: &ChaCha8Rng, alpha: f32) -> f32 {
    loss_with(sac, rng, alpha, None)
}

/// [`loss`], Lagrangian with `cost` if given.
fn loss_with(sac: &mut Sac, rng: &ChaCha8Rng, alpha: f32, cost: Option<&mut LagrangeTerm>) -> f32 {
    let (b, o, a) = (sac.config.batch_size, sac.obs_dim, sac.act_dim);
    sac.rng = rng.clone();
    copy_out(sac.actor.forward(rows(&sac.ws.batch.obs, b, o)), &mut sac.ws.actor_out);
    Sac::sample_policy(&mut sac.ws, &mut sac.rng, b, a, false);
    sac.actor_backward(alpha, cost.map(|c| c as &mut dyn CostTerm))
}

/// A cost critic of its own initialisation with a fixed multiplier (Lagrangian SAC's term).
struct LagrangeTerm {
    critic: crate::safety::cost_critic::CostCritic,
    lambda: f32,
}

impl CostTerm for LagrangeTerm {
    fn critic_step(&mut self, batch: &Batch, critic_in: &[f32], next_in: &[f32]) -> Result<(), RlError> {
        self.critic.step(batch, critic_in, next_in).map(|_| ())
    }
    fn multiplier(&self) -> f32 {
        self.lambda
    }
    fn actor_term(&mut self, pi_in: &[f32], weight: f32, dact: &mut [f32]) -> f32 {
        self.critic.actor_term(pi_in, weight, dact)
    }
    fn max_grad_norm(&self) -> Option<f32> {
        None
    }
}

/// A term with a bounded cost critic (costs in [0, 0.02]: Q_c in [0, 2], small enough for the f32
/// loss's difference quotients), else the linear one.
fn lagrange_term_of(sac: &Sac, lambda: f32, bounded: bool) -> LagrangeTerm {
    use crate::safety::cost_critic::{CostCritic, CostRange};
    let range = CostRange { per_step: bounded.then_some((0.0, 0.02)), max_grad_norm: None };
    LagrangeTerm { critic: CostCritic::new(&sac.config, 3, 2, 11, range).unwrap(), lambda }
}

fn lagrange_term(sac: &Sac, lambda: f32) -> LagrangeTerm {
    lagrange_term_of(sac, lambda, true)
}

#[test]
fn the_lagrangian_actor_gradient_matches_finite_differences() {
    for bounded in [true, false] {
        let sac = small(0.3);
        let mut term = lagrange_term_of(&sac, 0.7, bounded);
        check_actor_gradient_with(sac, 0.3, Some(&mut term));
    }
}

#[test]
fn the_lagrangian_actor_loss_is_sacs_plus_lambda_q_c_over_one_plus_lambda() {
    let mut sac = small(0.3);
    let rng = sac.rng.clone();
    let plain = loss(&mut sac, &rng, 0.3);
    let mut zero = lagrange_term(&sac, 0.0);
    assert_eq!(loss_with(&mut sac, &rng, 0.3, Some(&mut zero)), plain, "lambda 0 is SAC");
    let mut term = lagrange_term(&sac, 0.7);
    let lagrangian = loss_with(&mut sac, &rng, 0.3, Some(&mut term));
    // Q_c at the same actions, from the critic's network and its documented output map
    // (lo + scale * sigmoid output), not through the actor term under test.
    let mean_qc = term.critic.q_values(&sac.ws.pi_in).iter().sum::<f32>() / 8.0;
    assert!(mean_qc > 0.0 && mean_qc < 2.0, "{mean_qc}");
    let expected = (plain + 0.7 * mean_qc) / 1.7;
    assert!((lagrangian - expected).abs() < 1e-5, "{lagrangian} vs {expected}");
    assert!((lagrangian - plain).abs() > 1e-3, "the cost term must matter here");
}

#[test]
fn under_a_multiplier_the_cloning_term_is_weighed_as_sacs_terms_are() {
    // With the learner half, every term but the cost's is weighed by 1 / (1 + lambda): the
    // cloning term keeps its weight against the reward whatever the multiplier (an unweighed one
    // would outweigh the reward 1 + lambda times and turn a large multiplier into cloning).
    let config = SacConfig {
        ent_coef: EntCoef::Fixed(0.3),
        demos_in_replay: true,
        bc_weight: 2.0,
        ..SacConfig::default()
    };
    let mut sac = small_with(config);
    assert!(sac.ws.batch.bc.iter().any(|&w| w > 0.0), "the batch must hold demonstration rows");
    let rng = sac.rng.clone();
    let with_bc = loss(&mut sac, &rng, 0.3);
    let mut no_bc = small_with(SacConfig { bc_weight: 0.0, ..sac.config.clone() });
    assert!((with_bc - loss(&mut no_bc, &rng, 0.3)).abs() > 1e-3, "the cloning term must matter here");
    let mut term = lagrange_term(&sac, 9.0);
    let lagrangian = loss_with(&mut sac, &rng, 0.3, Some(&mut term));
    let mean_qc = term.critic.q_values(&sac.ws.pi_in).iter().sum::<f32>() / 8.0;
    let expected = (with_bc + 9.0 * mean_qc) / 10.0;
    assert!((lagrangian - expected).abs() < 1e-5, "{lagrangian} vs {expected}");
    let mut term = lagrange_term(&sac, 9.0);
    check_actor_gradient_with(sac, 0.3, Some(&mut term));
}

#[test]
fn actor_gradient_matches_finite_differences() {
    check_actor_gradient(small(0.3), 0.3);
}

#[test]
fn the_behaviour_cloning_gradient_matches_finite_differences_in_both_forms() {
    for bc_form in [BcForm::PerRow, BcForm::Authors] {
        let config = SacConfig {
            ent_coef: EntCoef::Fixed(0.3),
            demos_in_replay: true,
            bc_weight: 2.0,
            bc_form,
            ..SacConfig::default()
        };
        let sac = small_with(config);
        let share = sac.ws.batch.bc.iter().sum::<f32>();
        assert!(share > 0.0 && share < 8.0, "the batch must mix demonstration rows and others");
        check_actor_gradient(sac, 0.3);
    }
}

#[test]
fn the_two_forms_weigh_the_batch_as_documented() {
    let mut ws = Workspace::new(2, 1, 1);
    ws.pi_act.copy_from_slice(&[0.5, 0.0]);
    ws.batch.actions.copy_from_slice(&[0.0, 1.0]);
    ws.batch.bc.copy_from_slice(&[1.0, 0.0]);
    let mut c = SacConfig { bc_weight: 1.0, demos_in_replay: true, ..SacConfig::default() };
    // Per row: only row 0, (0.5^2) / (2 rows * 1 dim).
    assert!((Sac::behaviour_cloning(&mut ws, &c, 2, 1, 1.0) - 0.125).abs() < 1e-7);
    c.bc_form = BcForm::Authors;
    ws.dact.fill(0.0);
    // Authors: mean(bc) = 0.5 times the MSE of both rows, (0.25 + 1) / 2.
    assert!((Sac::behaviour_cloning(&mut ws, &c, 2, 1, 1.0) - 0.3125).abs() < 1e-7);
    // d/da~ of row 1: share 0.5 * 2 * (0 - 1) / (2 rows * 1 dim) = -0.5.
    assert!((ws.dact[1] + 0.5).abs() < 1e-7, "{:?}", ws.dact);
}

/// The actor's analytic gradient against central finite differences of its loss.
fn check_actor_gradient(sac: Sac, alpha: f32) {
    check_actor_gradient_with(sac, alpha, None);
}

/// [`check_actor_gradient`], Lagrangian with `cost` if given.
fn check_actor_gradient_with(mut sac: Sac, alpha: f32, mut cost: Option<&mut LagrangeTerm>) {
    let rng = sac.rng.clone();
    let mut loss = |sac: &mut Sac, rng: &ChaCha8Rng, alpha| loss_with(sac, rng, alpha, cost.as_deref_mut());
    loss(&mut sac, &rng, alpha);
    let analytic = sac.actor.grads().to_vec();
    let n = sac.actor.num_params();
    // Every parameter of the last layer (mean and log_std heads) and a spread of the others.
    let last = (n - (16 * 4 + 4))..n;
    let picked: Vec<usize> = (0..n).step_by(7).chain(last).collect();
    let h = 2e-3f32;
    let mut worst = 0.0f32;
    for &k in &picked {
        let p = sac.actor.params()[k];
        sac.actor.params_mut()[k] = p + h;
        let up = loss(&mut sac, &rng, alpha);
        sac.actor.params_mut()[k] = p - h;
        let down = loss(&mut sac, &rng, alpha);
        sac.actor.params_mut()[k] = p;
        let numeric = (up - down) / (2.0 * h);
        let err = (numeric - analytic[k]).abs() / (1e-3 + numeric.abs().max(analytic[k].abs()));
        worst = worst.max(err);
        assert!(err < 2e-2, "param {k}: analytic {} numeric {numeric}", analytic[k]);
    }
    assert!(analytic.iter().any(|g| g.abs() > 1e-4), "all gradients vanished");
    eprintln!("worst relative error {worst:e} over {} parameters", picked.len());
}

#[test]
fn log_prob_includes_the_tanh_correction() {
    // With mean 0 and log_std 0 (std 1), log pi(a) = log N(u; 0, 1) - log(1 - tanh(u)^2 + 1e-6).
    let mut ws = Workspace::new(1, 1, 1);
    ws.actor_out.copy_from_slice(&[0.0, 0.0]);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let eps: f32 = rng.clone().sample(StandardNormal);
    Sac::sample_policy(&mut ws, &mut rng, 1, 1, false);
    let expected =
        -0.5 * eps * eps - 0.5 * (2.0 * std::f32::consts::PI).ln() - (1.0 - eps.tanh().powi(2) + 1e-6).ln();
    assert!((ws.logp[0] - expected).abs() < 1e-5, "{} vs {expected}", ws.logp[0]);
    assert!((ws.pi_act[0] - eps.tanh()).abs() < 1e-7);
}

#[test]
fn warm_up_is_uniform_then_the_policy_acts_and_update_waits_for_learning_starts() {
    let config = SacConfig { learning_starts: 10, batch_size: 4, net_arch: vec![8], ..SacConfig::default() };
    let mut sac = Sac::new(config, 2, 1, 0).unwrap();
    let mut act = [0.0f32];
    for step in 0..12u64 {
        sac.act(&[0.1, 0.2], false, &mut act).unwrap();
        assert!((-1.0..=1.0).contains(&act[0]));
        let obs = [0.1, 0.2];
        let t = Transition {
            obs: &obs,
            action: &act,
            reward: 1.0,
            cost: 0.0,
            next_obs: &obs,
            terminated: false,
            truncated: true,
        };
        sac.observe(&t).unwrap();
        // SB3: the first update after step learning_starts + 1.
        assert_eq!(sac.update().unwrap().is_some(), step + 1 > 10, "step {step}");
    }
    let mut d1 = [0.0f32];
    let mut d2 = [0.0f32];
    sac.act(&[0.3, 0.4], true, &mut d1).unwrap();
    sac.act(&[0.3, 0.4], true, &mut d2).unwrap();
    assert_eq!(d1, d2, "the deterministic action must not depend on the RNG");
    assert!(sac.act(&[0.3], true, &mut d1).is_err());
}
