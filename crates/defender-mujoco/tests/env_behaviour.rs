//! Behaviour beyond parity: bad input, instability, reset distributions, the registry.

#![allow(clippy::unwrap_used)] // test helpers, outside #[test] functions

use std::sync::{Arc, Mutex};

use defender_mujoco::{EnvError, MujocoEnv, Task, make, registry, replay};
use defender_rl::Env;

#[test]
fn registry_matches_the_built_environments() {
    assert_eq!(registry().len(), 9);
    for spec in registry() {
        let env = make(spec.id).unwrap();
        assert_eq!(env.id(), spec.id);
        assert_eq!(env.observation_space().dim(), spec.obs_dim);
        assert_eq!(env.action_space().dim(), spec.act_dim);
        assert_eq!(env.max_episode_steps(), Some(spec.max_episode_steps));
        assert!(env.action_space().is_bounded());
        assert!(env.action_space().low().iter().all(|&l| l == -1.0));
        assert!(env.action_space().high().iter().all(|&h| h == 1.0));
    }
    let dims: Vec<(usize, usize)> = registry().iter().map(|s| (s.obs_dim, s.act_dim)).collect();
    assert_eq!(
        dims,
        [(11, 3), (17, 6), (9, 1), (11, 3), (17, 6), (17, 6), (11, 3), (17, 6), (17, 6)],
        "Gymnasium's dimensions"
    );
}

#[test]
fn unknown_id_is_an_error_listing_the_known_ids() {
    let err = make("Hopper-v3").unwrap_err();
    assert!(matches!(err, EnvError::UnknownEnv { .. }));
    let msg = err.to_string();
    for spec in registry() {
        assert!(msg.contains(spec.id), "{msg}");
    }
}

#[test]
fn bad_actions_are_errors_and_leave_the_episode_usable() {
    let mut env = make("Walker2d-v5").unwrap();
    assert!(matches!(env.step(&[0.0; 6]), Err(EnvError::NeedsReset)), "step before reset");
    env.reset(Some(3)).unwrap();
    let err = env.step(&[0.0; 5]).unwrap_err();
    assert!(matches!(err, EnvError::LengthMismatch { expected: 6, got: 5, .. }), "{err}");
    let err = env.step(&[0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0]).unwrap_err();
    assert!(matches!(err, EnvError::NonFinite { index: 2, .. }), "{err}");
    assert!(matches!(env.step(&[f64::INFINITY; 6]), Err(EnvError::NonFinite { index: 0, .. })));
    // Actions outside the box are not errors (as in Gymnasium); the physics clamps ctrl.
    let step = env.step(&[3.0; 6]).unwrap();
    assert_eq!(step.obs.len(), 17);
    // The control cost sees the raw action: 1e-3 * 6 * 9.
    let mut twin = MujocoEnv::new(Task::Walker2d).unwrap();
    twin.reset(Some(3)).unwrap();
    let clipped = twin.step(&[1.0; 6]).unwrap();
    assert_eq!(step.obs, clipped.obs, "ctrl is clamped to [-1, 1] by MuJoCo");
    assert!((clipped.reward - step.reward - 1e-3 * 6.0 * 8.0).abs() < 1e-12);
}

#[test]
fn a_terminated_episode_needs_a_reset() {
    let mut env = MujocoEnv::new(Task::InvertedDoublePendulum).unwrap();
    env.reset(Some(0)).unwrap();
    let mut steps = 0;
    loop {
        steps += 1;
        let step = env.step(&[1.0]).unwrap();
        assert!(!step.truncated);
        if step.terminated {
            assert_eq!(step.reward.min(10.0), step.reward);
            assert!(step.reward < 0.0, "no alive bonus on the terminal step: {}", step.reward);
            break;
        }
        assert!(steps < 100, "full force must topple the pendulum");
    }
    assert!(matches!(env.step(&[0.0]), Err(EnvError::NeedsReset)));
    env.reset(None).unwrap();
    assert!(env.step(&[0.0]).is_ok());
}

#[test]
fn set_state_is_validated_and_observed_as_gymnasium_does() {
    let mut env = MujocoEnv::new(Task::Hopper).unwrap();
    env.reset(Some(0)).unwrap();
    let before = (env.qpos().to_vec(), env.qvel().to_vec());
    assert!(matches!(
        env.set_state(&[0.0; 5], &[0.0; 6]),
        Err(EnvError::LengthMismatch { expected: 6, got: 5, .. })
    ));
    assert!(matches!(env.set_state(&[0.0; 6], &[0.0; 7]), Err(EnvError::LengthMismatch { .. })));
    assert!(matches!(
        env.set_state(&[0.0, 1.25, 0.0, f64::NAN, 0.0, 0.0], &[0.0; 6]),
        Err(EnvError::NonFinite { index: 3, .. })
    ));
    assert_eq!((env.qpos().to_vec(), env.qvel().to_vec()), before, "unchanged on error");

    let qpos = [7.0, 1.2, 0.1, -0.3, -0.2, 0.05];
    let qvel = [1.0, -50.0, 2.0, 11.0, -3.0, 0.5];
    env.set_state(&qpos, &qvel).unwrap();
    assert_eq!(env.qpos(), qpos);
    assert_eq!(env.qvel(), qvel);
    let obs = env.observation();
    assert_eq!(&obs[..5], &qpos[1..], "x position excluded");
    assert_eq!(&obs[5..], &[1.0, -10.0, 2.0, 10.0, -3.0, 0.5], "velocities clipped to [-10, 10]");
}

#[test]
fn reset_noise_follows_gymnasium_distributions_and_the_seed() {
    let mut hopper = MujocoEnv::new(Task::Hopper).unwrap();
    let a = hopper.reset(Some(11)).unwrap();
    let b = hopper.reset(Some(11)).unwrap();
    let c = hopper.reset(Some(12)).unwrap();
    assert_eq!(a, b, "same seed, same initial state");
    assert_ne!(a, c);
    let init_qpos = [0.0, 1.25, 0.0, 0.0, 0.0, 0.0];
    for _ in 0..200 {
        hopper.reset(None).unwrap();
        for (q, q0) in hopper.qpos().iter().zip(init_qpos) {
            assert!((q - q0).abs() < 5e-3);
        }
        assert!(hopper.qvel().iter().all(|v| v.abs() < 5e-3));
    }

    // InvertedDoublePendulum: qpos ~ U(-0.1, 0.1), qvel ~ 0.1 * N(0, 1).
    let mut idp = MujocoEnv::new(Task::InvertedDoublePendulum).unwrap();
    idp.reset(Some(5)).unwrap();
    let (mut sum_sq, mut max_abs_qpos, mut n) = (0.0, 0.0f64, 0.0);
    for _ in 0..400 {
        idp.reset(None).unwrap();
        max_abs_qpos = idp.qpos().iter().fold(max_abs_qpos, |m, q| m.max(q.abs()));
        for v in idp.qvel() {
            sum_sq += v * v;
            n += 1.0;
        }
    }
    assert!(max_abs_qpos < 0.1 && max_abs_qpos > 0.09, "{max_abs_qpos}");
    let std = (sum_sq / n).sqrt();
    assert!((std - 0.1).abs() < 0.01, "qvel noise std {std}");
}

#[test]
fn half_cheetah_resets_with_gaussian_velocities_and_observes_them_unclipped() {
    // half_cheetah_v4.py: qpos ~ U(-0.1, 0.1), qvel ~ 0.1 * N(0, 1), observation qpos[1:] and qvel.
    let mut env = MujocoEnv::new(Task::SafetyHalfCheetahVelocity).unwrap();
    env.reset(Some(5)).unwrap();
    let (mut sum_sq, mut max_abs_qpos, mut n) = (0.0, 0.0f64, 0.0);
    for _ in 0..300 {
        env.reset(None).unwrap();
        max_abs_qpos = env.qpos().iter().fold(max_abs_qpos, |m, q| m.max(q.abs()));
        for v in env.qvel() {
            sum_sq += v * v;
            n += 1.0;
        }
    }
    assert!(max_abs_qpos < 0.1 && max_abs_qpos > 0.09, "{max_abs_qpos}");
    let std = (sum_sq / n).sqrt();
    assert!((std - 0.1).abs() < 0.01, "qvel noise std {std}");
    let (qpos, mut qvel) = (env.qpos().to_vec(), env.qvel().to_vec());
    qvel[3] = 25.0;
    env.set_state(&qpos, &qvel).unwrap();
    let obs = env.observation();
    assert_eq!((&obs[..8], &obs[8..]), (&qpos[1..], &qvel[..]), "no clip on HalfCheetah's velocities");
}

/// Captures what `tracing` writes on this thread.
#[derive(Clone, Default)]
struct Capture(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Capture {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for Capture {
    type Writer = Capture;
    fn make_writer(&'a self) -> Capture {
        self.clone()
    }
}

fn with_captured_log<T>(f: impl FnOnce() -> T) -> (T, String) {
    let capture = Capture::default();
    let subscriber = tracing_subscriber::fmt().with_writer(capture.clone()).with_ansi(false).finish();
    let out = tracing::subscriber::with_default(subscriber, f);
    let text = String::from_utf8(capture.0.lock().unwrap().clone()).unwrap();
    (out, text)
}

#[test]
fn huge_velocities_end_the_episode_as_unstable_with_a_warning() {
    let mut env = MujocoEnv::new(Task::Hopper).unwrap();
    env.reset(Some(0)).unwrap();
    env.set_state(&[0.0, 1.25, 0.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 1e12, 0.0, 0.0, 0.0]).unwrap();
    let (step, log) = with_captured_log(|| env.step(&[0.0; 3]).unwrap());
    assert!(step.terminated && step.info.unstable && !step.truncated);
    assert_eq!(step.reward, 0.0);
    assert!(step.obs.iter().all(|v| v.is_finite()));
    assert!(log.contains("WARN") && log.contains("MuJoCo warned") && log.contains("Hopper-v5"), "{log}");
    assert!(log.contains("mujoco:"), "MuJoCo's own message goes to tracing: {log}");
    assert!(matches!(env.step(&[0.0; 3]), Err(EnvError::NeedsReset)));
    // The environment is usable again after a reset.
    env.reset(Some(1)).unwrap();
    let step = env.step(&[0.0; 3]).unwrap();
    assert!(!step.info.unstable && !step.terminated);
}

#[test]
fn instability_is_detected_again_after_set_state_without_reset() {
    let mut env = MujocoEnv::new(Task::Walker2d).unwrap();
    env.reset(Some(0)).unwrap();
    let mut qvel = vec![0.0; 9];
    qvel[4] = 1e15;
    for _ in 0..2 {
        let qpos = env.qpos().to_vec();
        env.set_state(&qpos, &qvel).unwrap();
        let step = env.step(&[0.0; 6]).unwrap();
        assert!(step.info.unstable && step.terminated);
    }
}

#[test]
fn absurd_actions_are_clamped_by_the_physics_or_unstable_not_a_panic() {
    // MuJoCo clamps ctrl to ctrlrange: a 1e300 force is the maximal one (IDP has no control cost).
    let mut a = MujocoEnv::new(Task::InvertedDoublePendulum).unwrap();
    let mut b = MujocoEnv::new(Task::InvertedDoublePendulum).unwrap();
    a.reset(Some(0)).unwrap();
    b.reset(Some(0)).unwrap();
    let huge = a.step(&[1e300]).unwrap();
    assert!(!huge.info.unstable);
    assert_eq!(huge, b.step(&[1.0]).unwrap());

    // Hopper's control cost of such an action overflows: the step is unstable, through replay too.
    let mut hopper = MujocoEnv::new(Task::Hopper).unwrap();
    let qpos = [0.0, 1.25, 0.0, 0.0, 0.0, 0.0];
    let actions = [0.0, 0.0, 0.0, 1e200, 0.0, 0.0, 0.0, 0.0, 0.0];
    let (rollout, log) = with_captured_log(|| replay(&mut hopper, &qpos, &[0.0; 6], &actions).unwrap());
    assert_eq!(rollout.steps(), 2);
    assert_eq!(rollout.terminated, [false, true]);
    assert_eq!(rollout.rewards[1], 0.0);
    assert!(rollout.unstable);
    assert!(log.contains("non-finite"), "{log}");
}

#[test]
fn replay_rejects_malformed_actions() {
    let mut env = MujocoEnv::new(Task::Hopper).unwrap();
    let qpos = [0.0, 1.25, 0.0, 0.0, 0.0, 0.0];
    let err = replay(&mut env, &qpos, &[0.0; 6], &[0.0; 4]).unwrap_err();
    assert!(matches!(err, EnvError::LengthMismatch { got: 4, .. }), "{err}");
    let err = replay(&mut env, &qpos, &[0.0; 6], &[0.0, 0.0, 0.0, 0.0, f64::NAN, 0.0]).unwrap_err();
    assert!(err.to_string().contains("row 1, column 1"), "{err}");
    let err = replay(&mut env, &qpos[..5], &[0.0; 6], &[0.0; 3]).unwrap_err();
    assert!(matches!(err, EnvError::LengthMismatch { expected: 6, got: 5, .. }), "{err}");
    let ok = replay(&mut env, &qpos, &[0.0; 6], &[]).unwrap();
    assert_eq!((ok.steps(), ok.obs.len()), (0, 11));
}

#[test]
fn environments_can_move_to_other_threads() {
    fn assert_send<T: Send + 'static>(_: &T) {}
    let env = make("Hopper-v5").unwrap();
    assert_send(&env);
    let handle = std::thread::spawn(move || {
        let mut env = env;
        env.reset(Some(0)).unwrap().len()
    });
    assert_eq!(handle.join().unwrap(), 11);
}
