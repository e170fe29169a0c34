//! Recovery RL's switch and action relabelling on hand-made safety critics, its pretraining
//! and its refusal to start without demonstrations.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::{Batch, ReplayBuffer, SacConfig};

const OBS: [f64; 2] = [0.1, -0.2];
const HIDDEN: usize = 8;

fn agent(pretrain_steps: u64) -> Recovery {
    let config = SacConfig {
        net_arch: vec![HIDDEN],
        batch_size: 4,
        buffer_size: 100,
        learning_starts: 0,
        ..SacConfig::default()
    };
    let task = Sac::new(config, 2, 1, 3).unwrap();
    let config =
        RecoveryConfig { gamma_risk: 0.8, eps_risk: 0.3, pretrain_steps, ..RecoveryConfig::default() };
    Recovery::new(task, config, 3).unwrap()
}

/// A crashed demonstration's last transition, elsewhere in the state space.
fn with_demo(mut agent: Recovery) -> Recovery {
    let t = Transition {
        obs: &[0.9, 0.9],
        action: &[0.5],
        reward: 1.0,
        cost: 1.0,
        next_obs: &[1.0, 1.0],
        terminated: true,
        truncated: false,
    };
    agent.store_demonstration(&t, false).unwrap();
    agent
}

/// Makes both safety critics output `sigmoid(logit)` everywhere: the last layer's weights 0,
/// its bias `logit`.
fn set_risk(agent: &mut Recovery, logit: f32) {
    set_risks(agent, [logit, logit]);
}

/// Makes safety critic `k` output `sigmoid(logits[k])` everywhere.
fn set_risks(agent: &mut Recovery, logits: [f32; 2]) {
    for (k, logit) in logits.into_iter().enumerate() {
        let p = agent.risk.critics.alone(k).net.params_mut();
        let n = p.len();
        p[n - HIDDEN - 1..n - 1].fill(0.0);
        p[n - 1] = logit;
    }
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

#[test]
fn the_switch_reads_the_larger_critic_strictly_above_eps_risk() {
    // One critic above eps_risk (0.3), the other below: Q_risk is the larger, so the recovery
    // policy acts (a min would not switch).
    for logits in [[0.0, -3.0], [-3.0, 0.0]] {
        let mut agent = with_demo(agent(0));
        agent.pretrain().unwrap();
        set_risks(&mut agent, logits);
        assert_eq!(agent.risk(&OBS, &[0.0]).unwrap(), 0.5, "{logits:?}");
        agent.act(&OBS, false, &mut [0.0]).unwrap();
        assert_eq!(agent.recovery_steps(), 1, "{logits:?}");
    }
    // Q_risk exactly at eps_risk: not above it, the task's action stands (>= would switch).
    let at = sigmoid(-1.0);
    let task = Sac::new(agent(0).task.config().clone(), 2, 1, 3).unwrap();
    let config = RecoveryConfig { eps_risk: f64::from(at), pretrain_steps: 0, ..RecoveryConfig::default() };
    let mut agent = with_demo(Recovery::new(task, config, 3).unwrap());
    agent.pretrain().unwrap();
    set_risks(&mut agent, [-1.0, -4.0]);
    assert_eq!(agent.risk(&OBS, &[0.0]).unwrap(), at);
    agent.act(&OBS, false, &mut [0.0]).unwrap();
    assert_eq!(agent.recovery_steps(), 0);
}

/// The actions `buffer` holds for transitions from `OBS` (sampled often enough to see them).
fn stored_actions(buffer: &ReplayBuffer) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut batch = Batch::new(64, 2, 1);
    buffer.sample_into(&mut rng, &mut batch).unwrap();
    let mut actions: Vec<f32> = (0..64)
        .filter(|&i| batch.obs[2 * i..2 * i + 2] == [OBS[0] as f32, OBS[1] as f32])
        .map(|i| batch.actions[i])
        .collect();
    actions.dedup();
    actions
}

/// One exploration step from `OBS` under a safety critic fixed at `sigmoid(logit)`: the
/// proposed action (from a copy of the task agent), the recovery policy's (from a copy of the
/// safety critic) and the executed one; the agent after observing its transition.
fn step(logit: f32) -> (f32, f32, f32, Recovery) {
    let mut agent = with_demo(agent(0));
    agent.pretrain().unwrap();
    set_risk(&mut agent, logit);
    let (mut proposed, mut recovery, mut executed) = ([0.0f32], [0.0f32], [0.0f32]);
    agent.task.clone().act(&OBS, false, &mut proposed).unwrap();
    let mut risk = agent.risk.clone();
    risk.policy.act(&[OBS[0] as f32, OBS[1] as f32], false, &mut risk.rng, &mut recovery);
    agent.act(&OBS, false, &mut executed).unwrap();
    let t = Transition {
        obs: &OBS,
        action: &executed,
        reward: 0.5,
        cost: 0.0,
        next_obs: &[0.2, -0.1],
        terminated: false,
        truncated: false,
    };
    agent.observe(&t).unwrap();
    (proposed[0], recovery[0], executed[0], agent)
}

#[test]
fn above_the_threshold_the_recovery_action_is_executed_and_the_task_buffer_keeps_the_proposal() {
    let (proposed, recovery, executed, mut agent) = step(10.0);
    assert!(agent.risk(&OBS, &[proposed]).unwrap() > 0.3);
    assert_eq!(executed, recovery);
    assert_ne!(executed, proposed);
    assert_eq!(agent.recovery_steps(), 1);
    assert_eq!(stored_actions(agent.task.buffer()), [proposed], "the task buffer: the proposed action");
    assert_eq!(stored_actions(&agent.risk.buffer), [executed], "Q_risk's buffer: the executed action");
}

#[test]
fn below_the_threshold_the_task_action_is_executed_and_both_buffers_keep_it() {
    let (proposed, _, executed, mut agent) = step(-10.0);
    assert!(agent.risk(&OBS, &[proposed]).unwrap() < 0.3);
    assert_eq!(executed, proposed);
    assert_eq!(agent.recovery_steps(), 0);
    assert_eq!(stored_actions(agent.task.buffer()), [proposed]);
    assert_eq!(stored_actions(&agent.risk.buffer), [proposed]);
}

#[test]
fn evaluation_is_the_task_policy_alone() {
    let mut agent = with_demo(agent(0));
    agent.pretrain().unwrap();
    set_risk(&mut agent, 10.0);
    let (mut shielded, mut task) = ([0.0f32], [0.0f32]);
    agent.act(&OBS, true, &mut shielded).unwrap();
    agent.task.act(&OBS, true, &mut task).unwrap();
    assert_eq!(shielded, task);
    assert_eq!(agent.recovery_steps(), 0);
}

#[test]
fn without_demonstrations_the_first_step_is_refused_naming_the_key() {
    let mut agent = agent(10);
    match agent.act(&OBS, false, &mut [0.0]) {
        Err(RlError::Config { field, .. }) => assert_eq!(field, "demos"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn pretraining_runs_once_then_the_critic_follows_the_task_updates() {
    let mut agent = with_demo(agent(5));
    assert!(!agent.pretrained());
    let mut action = [0.0f32];
    agent.act(&OBS, false, &mut action).unwrap();
    assert!(agent.pretrained());
    assert_eq!(agent.risk.n_updates, 5);
    agent.act(&OBS, false, &mut action).unwrap();
    assert_eq!(agent.risk.n_updates, 5, "pretraining is not repeated");
    for _ in 0..4 {
        agent.act(&OBS, false, &mut action).unwrap();
        let t = Transition {
            obs: &OBS,
            action: &action,
            reward: 0.5,
            cost: 0.0,
            next_obs: &OBS,
            terminated: false,
            truncated: false,
        };
        agent.observe(&t).unwrap();
    }
    let stats = agent.update().unwrap().expect("an update is due");
    assert_eq!(agent.risk.n_updates, 5 + stats.n_updates);
    assert_eq!(stats.recovery_steps, Some(agent.recovery_steps()));
}
