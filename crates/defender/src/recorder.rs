//! Recording episodes step by step into an [`EpisodeSet`] (for `collect` and for recording the
//! training episodes the ablation replays).

use crate::episode_set::EpisodeSet;
use crate::error::{DefenderError, Result};

/// Accumulates one episode at a time from an environment's f64 data and appends it to a set.
/// Buffers are reused from episode to episode.
#[derive(Debug, Clone, Default)]
pub struct EpisodeRecorder {
    obs: Vec<f64>,
    act: Vec<f64>,
    rew: Vec<f64>,
    started: bool,
}

impl EpisodeRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts an episode with its first observation (from `reset`), dropping any unfinished one.
    pub fn start(&mut self, obs: &[f64]) {
        self.obs.clear();
        self.act.clear();
        self.rew.clear();
        self.obs.extend_from_slice(obs);
        self.started = true;
    }

    /// Records one transition: the action taken, its reward and the observation that followed.
    ///
    /// # Errors
    /// No episode was started.
    pub fn step(&mut self, action: &[f64], reward: f64, next_obs: &[f64]) -> Result<()> {
        if !self.started {
            return Err(DefenderError::Config("EpisodeRecorder::step before start".into()));
        }
        self.act.extend_from_slice(action);
        self.rew.push(reward);
        self.obs.extend_from_slice(next_obs);
        Ok(())
    }

    /// Transitions recorded in the current episode.
    pub fn len(&self) -> usize {
        self.rew.len()
    }

    /// Whether the current episode has no transition yet.
    pub fn is_empty(&self) -> bool {
        self.rew.is_empty()
    }

    /// Ends the episode and appends it to `set` with its `crashed` flag (SPEC section 6: the
    /// environment terminated it). The recorder is then ready for [`EpisodeRecorder::start`].
    ///
    /// # Errors
    /// No transition was recorded, or the data do not fit the set's dimensions or are not finite
    /// (the set is unchanged then).
    pub fn finish(&mut self, set: &mut EpisodeSet, crashed: bool) -> Result<()> {
        self.started = false;
        set.push_episode_f64(&self.obs, &self.act, &self.rew, crashed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode_set::Meta;

    #[test]
    fn records_episodes_into_a_set() {
        let mut set = EpisodeSet::new(2, 1, Meta::default()).unwrap();
        let mut rec = EpisodeRecorder::new();
        assert!(rec.step(&[0.0], 0.0, &[0.0, 0.0]).is_err());
        rec.start(&[0.0, 1.0]);
        rec.step(&[0.5], 1.0, &[1.0, 1.0]).unwrap();
        rec.step(&[0.5], 2.0, &[2.0, 1.0]).unwrap();
        assert_eq!(rec.len(), 2);
        rec.finish(&mut set, true).unwrap();
        rec.start(&[9.0, 9.0]);
        assert!(rec.finish(&mut set, false).is_err(), "an episode needs a transition");
        assert_eq!(set.len(), 1);
        let e = set.episode(0);
        assert_eq!((e.len(), e.crashed, e.observation(2)), (2, true, &[2.0f32, 1.0][..]));
    }
}
