//! SAC's Bellman target: what bootstraps and what does not.

use super::*;

/// Whether every Bellman target of one gradient step equals its reward (no bootstrap), after 20
/// transitions ending as `terminated` / `truncated` say, under `config`.
fn targets_are_rewards(config: SacConfig, terminated: bool, truncated: bool) -> bool {
    let config = SacConfig { net_arch: vec![8], batch_size: 16, learning_starts: 0, ..config };
    let mut sac = Sac::new(config, 2, 1, 0).unwrap();
    for i in 0..20 {
        let x = f64::from(i) / 20.0;
        let t = Transition {
            obs: &[x, -x],
            action: &[0.5],
            reward: x,
            cost: 0.0,
            next_obs: &[x, x],
            terminated,
            truncated,
        };
        sac.observe(&t).unwrap();
    }
    sac.gradient_step(None).unwrap();
    sac.ws.target.iter().zip(&sac.ws.batch.rewards).all(|(y, r)| y == r)
}

#[test]
fn terminated_transitions_do_not_bootstrap_and_truncated_ones_do() {
    for terminated in [true, false] {
        let same = targets_are_rewards(SacConfig::default(), terminated, !terminated);
        assert_eq!(same, terminated, "terminated = {terminated}");
    }
}

#[test]
fn with_terminal_on_truncation_a_time_limit_cut_does_not_bootstrap() {
    let config = SacConfig { terminal_on_truncation: true, ..SacConfig::default() };
    assert!(targets_are_rewards(config, false, true));
}
