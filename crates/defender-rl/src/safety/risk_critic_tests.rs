//! The recovery policy's gradient through the sigmoid safety critics, against finite differences;
//! the safety critic's target and Polyak step on fixed target critics.

use rand::{Rng, SeedableRng};

use super::*;
use crate::SacConfig;

/// A small safety critic with a filled buffer and a sampled batch.
fn critic() -> RiskCritic {
    let shape = RiskShape {
        obs_dim: 3,
        act_dim: 2,
        net_arch: vec![16, 16],
        learning_rate: 3e-4,
        batch_size: 8,
        buffer_size: 100,
        gamma_risk: 0.8,
        pos_fraction: 0.0,
    };
    let mut rc = RiskCritic::new(shape, 5).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for k in 0..40 {
        let obs: Vec<f64> = (0..3).map(|_| rng.random_range(-1.0..1.0)).collect();
        let next: Vec<f64> = (0..3).map(|_| rng.random_range(-1.0..1.0)).collect();
        let act: Vec<f32> = (0..2).map(|_| rng.random_range(-1.0..1.0)).collect();
        let crash = k % 5 == 0;
        let t = Transition {
            obs: &obs,
            action: &act,
            reward: 0.0,
            cost: if crash { 1.0 } else { 0.0 },
            next_obs: &next,
            terminated: crash,
            truncated: false,
        };
        rc.push(&t).unwrap();
    }
    rc.buffer.sample_into(&mut rc.rng, &mut rc.ws.batch).unwrap();
    rc
}

/// The policy's loss for its current parameters, with the noise drawn from `rng`.
fn loss(rc: &mut RiskCritic, rng: &ChaCha8Rng) -> f32 {
    rc.rng = rng.clone();
    rc.policy_backward()
}

#[test]
fn the_recovery_policys_gradient_matches_finite_differences() {
    let mut rc = critic();
    let rng = rc.rng.clone();
    loss(&mut rc, &rng);
    let analytic = rc.policy.net.grads().to_vec();
    let analytic_std = rc.policy.log_std_grad.clone();
    let h = 3e-3f32;
    let check = |numeric: f32, analytic: f32, what: &str| {
        let err = (numeric - analytic).abs() / (1e-3 + numeric.abs().max(analytic.abs()));
        assert!(err < 2e-2, "{what}: analytic {analytic} numeric {numeric}");
    };
    let n = rc.policy.net.num_params();
    for k in (0..n).step_by(5).chain(n - 34..n) {
        let p = rc.policy.net.params()[k];
        rc.policy.net.params_mut()[k] = p + h;
        let up = loss(&mut rc, &rng);
        rc.policy.net.params_mut()[k] = p - h;
        let down = loss(&mut rc, &rng);
        rc.policy.net.params_mut()[k] = p;
        check((up - down) / (2.0 * h), analytic[k], &format!("param {k}"));
    }
    for (j, &g) in analytic_std.iter().enumerate() {
        let p = rc.policy.std.log_std[j];
        rc.policy.std.log_std[j] = p + h;
        let up = loss(&mut rc, &rng);
        rc.policy.std.log_std[j] = p - h;
        let down = loss(&mut rc, &rng);
        rc.policy.std.log_std[j] = p;
        check((up - down) / (2.0 * h), g, &format!("log_std {j}"));
    }
    assert!(analytic.iter().any(|g| g.abs() > 1e-5), "all gradients vanished");
}

#[test]
fn the_target_bootstraps_the_larger_target_critic_unless_terminated_and_polyak_moves_by_tau() {
    // Three transitions: a crash (cost 1, terminated), a plain step, a time-limit cut (truncated,
    // which bootstraps); the target critics fixed at sigmoid(-2) and sigmoid(1) everywhere.
    let shape = RiskShape {
        obs_dim: 1,
        act_dim: 1,
        net_arch: vec![4],
        learning_rate: 3e-4,
        batch_size: 16,
        buffer_size: 10,
        gamma_risk: 0.9,
        pos_fraction: 0.0,
    };
    let mut rc = RiskCritic::new(shape, 2).unwrap();
    let kinds = [(1.0, true, false), (0.0, false, false), (0.0, false, true)];
    for (k, &(cost, terminated, truncated)) in kinds.iter().enumerate() {
        let x = [k as f64];
        let t =
            Transition { obs: &x, action: &[0.0], reward: 0.0, cost, next_obs: &x, terminated, truncated };
        rc.push(&t).unwrap();
    }
    for (k, logit) in [(0, -2.0f32), (1, 1.0)] {
        let p = rc.critics.alone(k).target.params_mut();
        let n = p.len();
        p[n - 5..n - 1].fill(0.0);
        p[n - 1] = logit;
    }
    let before: Vec<Vec<f32>> = (0..2).map(|k| rc.critics[k].target.params().to_vec()).collect();
    let sac = SacConfig { net_arch: vec![4], batch_size: 16, ..SacConfig::default() };
    let mut task = Sac::new(sac, 1, 1, 0).unwrap();
    rc.gradient_step(&mut task).unwrap();
    let larger = 1.0 / (1.0 + (-1.0f32).exp());
    let mut seen = [false; 3];
    for row in 0..16 {
        let kind = rc.ws.batch.obs[row] as usize;
        seen[kind] = true;
        let expected = if kind == 0 { 1.0 } else { 0.9 * larger };
        assert!(
            (rc.ws.target[row] - expected).abs() < 1e-6,
            "row {row} (kind {kind}): {}",
            rc.ws.target[row]
        );
    }
    assert_eq!(seen, [true; 3], "the batch mixes the three kinds");
    // Qt <- TAU Q + (1 - TAU) Qt, after the critics' step.
    for (k, before) in before.iter().enumerate() {
        let (online, target) = (rc.critics[k].net.params(), rc.critics[k].target.params());
        for ((t, b), q) in target.iter().zip(before).zip(online) {
            assert!((t - (TAU_RISK * q + (1.0 - TAU_RISK) * b)).abs() < 1e-6, "critic {k}");
        }
    }
}
