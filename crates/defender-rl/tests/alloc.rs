//! No allocation per transition or per update once the buffers exist (single-threaded
//! networks: faer's parallel GEMM allocates task objects, see defender-nn's alloc test).

use defender_nn::Parallelism;
use defender_rl::{Agent, Sac, SacConfig, Td3, Td3Config, Transition};

#[global_allocator]
static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;

/// Acts, stores and updates `steps` times; returns the allocations counted.
fn cycle(agent: &mut dyn Agent, steps: usize) -> u64 {
    let obs = [0.1, -0.2, 0.3];
    let next = [0.2, -0.1, 0.0];
    let mut action = [0.0f32; 2];
    let before = alloc_counter::allocations();
    for i in 0..steps {
        agent.act(&obs, false, &mut action).expect("act");
        let t = Transition {
            obs: &obs,
            action: &action,
            reward: 1.0,
            cost: 0.0,
            next_obs: &next,
            terminated: i % 7 == 0,
            truncated: false,
        };
        agent.observe(&t).expect("observe");
        agent.update().expect("update");
        agent.act(&obs, true, &mut action).expect("act");
    }
    alloc_counter::allocations() - before
}

#[test]
fn steady_state_training_steps_allocate_nothing() {
    let mut sac =
        Sac::new(SacConfig { net_arch: vec![32, 32], learning_starts: 20, ..SacConfig::default() }, 3, 2, 0)
            .unwrap();
    sac.set_parallelism(Parallelism::Sequential);
    let mut td3 =
        Td3::new(Td3Config { net_arch: vec![32, 32], learning_starts: 20, ..Td3Config::default() }, 3, 2, 0)
            .unwrap();
    td3.set_parallelism(Parallelism::Sequential);
    for agent in [&mut sac as &mut dyn Agent, &mut td3] {
        cycle(agent, 30); // warm-up and the first updates grow the networks' workspaces
        assert_eq!(cycle(agent, 40), 0, "{}", agent.algo());
    }
}
