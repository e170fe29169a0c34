//! Timing training runs: a `Hooks` clock that times each step after the warm-up, and turns that
//! let several runs share the machine's load.

use std::time::Instant;

use defender_mujoco::MujocoEnv;
use defender_rl::{Agent, Env, EpisodeRecord, HookError, Hooks, TimeLimit, Trainer};

use super::machine::process_cpu_seconds;

/// The timed steps of one training run.
#[derive(Debug, Clone, Copy)]
pub(super) struct Timing {
    pub(super) seconds: f64,
    pub(super) cpu_seconds: Option<f64>,
    pub(super) steps: u64,
    pub(super) episodes: u64,
    pub(super) filtered: u64,
}

impl Timing {
    pub(super) fn ms_per_step(&self) -> f64 {
        self.seconds * 1e3 / self.steps as f64
    }
    pub(super) fn cores(&self) -> String {
        self.cpu_seconds.map_or(String::new(), |c| format!("; CPU {:.2} cores", c / self.seconds))
    }
}

/// Times a training run step by step, in segments: it asks the trainer to stop at the first
/// episode boundary after `stop_at` steps, so that several runs can take turns and see the same
/// machine load. A step is timed from the end of the previous step to its own end (the agent's
/// action, the environment step, the update and any reset in between); the first step of each
/// segment and the warm-up steps (up to `learning_starts`) are not timed.
pub(super) struct SegmentClock {
    learning_starts: u64,
    total: u64,
    stop_at: u64,
    steps_seen: u64,
    last: Option<Instant>,
    cpu_start: Option<f64>,
    cpu_ok: bool,
    timing: Timing,
}

impl SegmentClock {
    pub(super) fn new(learning_starts: u64, total: u64) -> Self {
        Self {
            learning_starts,
            total,
            stop_at: 0,
            steps_seen: 0,
            last: None,
            cpu_start: None,
            cpu_ok: true,
            timing: Timing { seconds: 0.0, cpu_seconds: Some(0.0), steps: 0, episodes: 0, filtered: 0 },
        }
    }

    pub(super) fn done(&self) -> bool {
        self.steps_seen >= self.total
    }

    pub(super) fn end_segment(&mut self) {
        if self.last.take().is_some() {
            match (self.cpu_start.take(), process_cpu_seconds(), self.timing.cpu_seconds.as_mut()) {
                (Some(a), Some(b), Some(sum)) if self.cpu_ok => *sum += b - a,
                _ => self.cpu_ok = false,
            }
        }
    }

    pub(super) fn timing(&self) -> Timing {
        Timing { cpu_seconds: self.timing.cpu_seconds.filter(|_| self.cpu_ok), ..self.timing }
    }
}

impl Hooks for SegmentClock {
    fn on_step(&mut self, total_steps: u64) {
        self.steps_seen = total_steps;
        if total_steps < self.learning_starts {
            return;
        }
        let now = Instant::now();
        match self.last {
            Some(last) => {
                self.timing.seconds += (now - last).as_secs_f64();
                self.timing.steps += 1;
            }
            None => self.cpu_start = process_cpu_seconds(),
        }
        self.last = Some(now);
        if total_steps >= self.total {
            self.end_segment();
        }
    }
    fn on_episode_end(&mut self, record: &EpisodeRecord) -> Result<(), HookError> {
        if record.total_steps > self.learning_starts {
            self.timing.episodes += 1;
            // A filtered episode ends on its one filtered step.
            self.timing.filtered += u64::from(record.filtered);
        }
        Ok(())
    }
    fn should_stop(&mut self) -> bool {
        let stop = self.steps_seen >= self.stop_at && !self.done();
        if stop {
            self.end_segment();
        }
        stop
    }
}

pub(super) type AnyTrainer = Trainer<Box<dyn Agent>, Box<dyn Env>, TimeLimit<MujocoEnv>>;

/// Runs the trainers in turns of about `segment` steps each until all have spent their budget.
pub(super) fn take_turns(runs: &mut [(AnyTrainer, SegmentClock)], segment: u64) -> anyhow::Result<()> {
    loop {
        let mut active = false;
        for (trainer, clock) in runs.iter_mut() {
            if clock.done() {
                continue;
            }
            active = true;
            clock.stop_at = clock.steps_seen.max(clock.learning_starts) + segment;
            trainer.run(clock)?;
        }
        if !active {
            return Ok(());
        }
    }
}
