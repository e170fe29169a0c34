//! `Env::failure_proximity` (the `margin` trigger's reading of a task's failure condition) against
//! the simulator: computed from an observation's columns, it must pass 1 exactly when the task
//! terminates (Hopper, Walker2d), or within one integration substep of it (InvertedDoublePendulum,
//! whose termination reads the tip's height before the step's last substep).

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

use defender_rl::Env;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random episodes of `id`: `(proximity of each observation after a step, terminated)`.
fn rollouts(id: &str, episodes: u64) -> Vec<(f64, bool)> {
    let mut env = defender_mujoco::make(id).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let dim = env.action_space().dim();
    let mut seen = Vec::new();
    for episode in 0..episodes {
        let obs = env.reset(Some(episode)).unwrap();
        assert!(env.failure_proximity(&obs).unwrap() < 0.5, "{id}: a fresh episode starts far from failure");
        loop {
            let action: Vec<f64> = (0..dim).map(|_| rng.random_range(-1.0..1.0)).collect();
            let step = env.step(&action).unwrap();
            assert!(!step.info.unstable);
            seen.push((env.failure_proximity(&step.obs).unwrap(), step.terminated));
            if step.done() {
                break;
            }
        }
    }
    seen
}

#[test]
fn hopper_and_walker2d_fail_exactly_where_the_proximity_passes_one() {
    for id in ["Hopper-v5", "Walker2d-v5"] {
        let seen = rollouts(id, 30);
        let falls = seen.iter().filter(|(_, t)| *t).count();
        assert!(falls >= 25, "{id}: {falls} falls in 30 random episodes");
        for (p, terminated) in seen {
            assert_eq!(p >= 1.0, terminated, "{id}: proximity {p}, terminated {terminated}");
        }
    }
}

#[test]
fn the_double_pendulum_fails_where_its_tip_falls_to_one_metre() {
    let seen = rollouts("InvertedDoublePendulum-v5", 30);
    let falls = seen.iter().filter(|(_, t)| *t).count();
    assert!(falls >= 25, "{falls} falls in 30 random episodes");
    for (p, terminated) in seen {
        if terminated {
            assert!(p > 0.85, "terminated at proximity {p}");
        } else {
            assert!(p < 1.15, "not terminated at proximity {p}");
        }
    }
}

#[test]
fn tasks_without_a_failure_condition_have_no_proximity() {
    let env = defender_mujoco::make("HalfCheetah-v4").unwrap();
    assert_eq!(env.failure_proximity(&[0.0; 17]), None);
}
