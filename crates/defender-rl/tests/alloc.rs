//! No allocation per transition or per update once the buffers exist (single-threaded
//! networks: faer's parallel GEMM allocates task objects, see defender-nn's alloc test).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};

use defender_nn::Parallelism;
use defender_rl::{Agent, Sac, SacConfig, Td3, Td3Config, Transition};

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Acts, stores and updates `steps` times; returns the allocations counted.
fn cycle(agent: &mut dyn Agent, steps: usize) -> u64 {
    let obs = [0.1, -0.2, 0.3];
    let next = [0.2, -0.1, 0.0];
    let mut action = [0.0f32; 2];
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for i in 0..steps {
        agent.act(&obs, false, &mut action).expect("act");
        let t = Transition {
            obs: &obs,
            action: &action,
            reward: 1.0,
            next_obs: &next,
            terminated: i % 7 == 0,
            truncated: false,
        };
        agent.observe(&t).expect("observe");
        agent.update().expect("update");
        agent.act(&obs, true, &mut action).expect("act");
    }
    ALLOCATIONS.load(Ordering::Relaxed) - before
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
