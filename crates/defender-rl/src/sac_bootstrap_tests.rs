//! SAC's Bellman target: what bootstraps and what does not.

use super::*;

#[test]
fn terminated_transitions_do_not_bootstrap_and_truncated_ones_do() {
    for terminated in [true, false] {
        let config =
            SacConfig { net_arch: vec![8], batch_size: 16, learning_starts: 0, ..SacConfig::default() };
        let mut sac = Sac::new(config, 2, 1, 0).unwrap();
        for i in 0..20 {
            let x = f64::from(i) / 20.0;
            let t = Transition {
                obs: &[x, -x],
                action: &[0.5],
                reward: x,
                next_obs: &[x, x],
                terminated,
                truncated: !terminated,
            };
            sac.observe(&t).unwrap();
        }
        sac.gradient_step().unwrap();
        let same = sac.ws.target.iter().zip(&sac.ws.batch.rewards).all(|(y, r)| y == r);
        assert_eq!(same, terminated, "terminated = {terminated}");
    }
}

#[test]
fn with_terminal_on_truncation_a_time_limit_cut_does_not_bootstrap() {
    let config = SacConfig {
        net_arch: vec![8],
        batch_size: 16,
        learning_starts: 0,
        terminal_on_truncation: true,
        ..SacConfig::default()
    };
    let mut sac = Sac::new(config, 2, 1, 0).unwrap();
    for i in 0..20 {
        let x = f64::from(i) / 20.0;
        let t = Transition {
            obs: &[x, -x],
            action: &[0.5],
            reward: x,
            next_obs: &[x, x],
            terminated: false,
            truncated: true,
        };
        sac.observe(&t).unwrap();
    }
    sac.gradient_step().unwrap();
    assert!(sac.ws.target.iter().zip(&sac.ws.batch.rewards).all(|(y, r)| y == r));
}
