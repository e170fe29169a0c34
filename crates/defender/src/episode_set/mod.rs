//! Episode sets (SPEC sections 1 and 8): demonstration sets and recorded episode sets as the
//! project holds them in memory, their groups and the demonstrations a run uses. The `.npz` file
//! format and its validation are `file.rs`; one episode, borrowed, is [`Episode`] (`episode.rs`).

mod episode;
mod file;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{DefenderError, Result};
use crate::npz::bad;

pub use episode::Episode;
use file::check_finite;

/// The `meta` array of an episode-set file: UTF-8 JSON describing the set. Every field is
/// optional on read (a file written by hand may carry none); the ones present must agree with the
/// arrays. Keys this struct does not know are kept in `extra` and written back.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// The Gymnasium id of the environment (e.g. `Hopper-v5`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub env_id: Option<String>,
    /// Observation dimension.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obs_dim: Option<usize>,
    /// Action dimension.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub act_dim: Option<usize>,
    /// How the set was made (free text: program, agent, seed, date ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<String>,
    /// Any other keys.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// A set of episodes: every episode's observations (the final one included), actions, rewards and
/// whether it crashed. Stored as the concatenated arrays of SPEC section 8, in f32.
///
/// A *demonstration set* is an episode set whose crashed episodes form the unsafe group and the
/// others the safe group; a *recorded episode set* is the input of the offline ablation.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeSet {
    source: PathBuf,
    obs_dim: usize,
    act_dim: usize,
    obs: Vec<f32>,
    act: Vec<f32>,
    rew: Vec<f32>,
    ep_len: Vec<usize>,
    crashed: Vec<bool>,
    /// Row offsets of each episode in `obs` (and, minus the episode index, in `act` / `rew`).
    obs_start: Vec<usize>,
    meta: Meta,
}

const MEMORY: &str = "<memory>";

impl EpisodeSet {
    /// An empty set for an environment with these dimensions; fill it with
    /// [`EpisodeSet::push_episode`]. `meta.obs_dim` / `meta.act_dim` are set from the arguments.
    ///
    /// # Errors
    /// A dimension is zero.
    pub fn new(obs_dim: usize, act_dim: usize, mut meta: Meta) -> Result<Self> {
        if obs_dim == 0 || act_dim == 0 {
            return Err(DefenderError::Config(format!(
                "an episode set needs obs_dim >= 1 and act_dim >= 1, got {obs_dim} and {act_dim}"
            )));
        }
        meta.obs_dim = Some(obs_dim);
        meta.act_dim = Some(act_dim);
        Ok(Self {
            source: PathBuf::from(MEMORY),
            obs_dim,
            act_dim,
            obs: Vec::new(),
            act: Vec::new(),
            rew: Vec::new(),
            ep_len: Vec::new(),
            crashed: Vec::new(),
            obs_start: Vec::new(),
            meta,
        })
    }

    /// Appends one episode of `N >= 1` transitions: `N + 1` observations (the final one included),
    /// `N` actions and `N` rewards, all row-major f32.
    ///
    /// # Errors
    /// Lengths that do not fit `N` transitions of this set's dimensions, or non-finite values; the
    /// set is unchanged then.
    pub fn push_episode(&mut self, obs: &[f32], act: &[f32], rew: &[f32], crashed: bool) -> Result<()> {
        let n = rew.len();
        let path = self.source.clone();
        if n == 0 {
            return Err(bad(&path, "rew", "at least one transition per episode", "0 rewards"));
        }
        if obs.len() != (n + 1) * self.obs_dim {
            return Err(bad(
                &path,
                "obs",
                &format!(
                    "{} values ({} observations of dim {})",
                    (n + 1) * self.obs_dim,
                    n + 1,
                    self.obs_dim
                ),
                format!("{}", obs.len()),
            ));
        }
        if act.len() != n * self.act_dim {
            return Err(bad(
                &path,
                "act",
                &format!("{} values ({n} actions of dim {})", n * self.act_dim, self.act_dim),
                format!("{}", act.len()),
            ));
        }
        for (name, v) in [("obs", obs), ("act", act), ("rew", rew)] {
            check_finite(&path, name, v)?;
        }
        self.obs_start.push(self.obs.len() / self.obs_dim);
        self.obs.extend_from_slice(obs);
        self.act.extend_from_slice(act);
        self.rew.extend_from_slice(rew);
        self.ep_len.push(n);
        self.crashed.push(crashed);
        Ok(())
    }

    /// [`EpisodeSet::push_episode`] for f64 data as environments produce it (stored as f32).
    ///
    /// # Errors
    /// As [`EpisodeSet::push_episode`].
    pub fn push_episode_f64(&mut self, obs: &[f64], act: &[f64], rew: &[f64], crashed: bool) -> Result<()> {
        let f = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        self.push_episode(&f(obs), &f(act), &f(rew), crashed)
    }

    /// Where the set came from (its file, or `<memory>`); errors name it.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// The set's metadata.
    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    /// The set's metadata, mutably (e.g. to add provenance before saving).
    pub fn meta_mut(&mut self) -> &mut Meta {
        &mut self.meta
    }

    /// Number of episodes `E`.
    pub fn len(&self) -> usize {
        self.ep_len.len()
    }

    /// Whether the set has no episode.
    pub fn is_empty(&self) -> bool {
        self.ep_len.is_empty()
    }

    /// Total number of transitions.
    pub fn transitions(&self) -> usize {
        self.rew.len()
    }

    /// Episode `i` (file order).
    ///
    /// # Panics
    /// `i >= self.len()`.
    pub fn episode(&self, i: usize) -> Episode<'_> {
        let n = self.ep_len[i];
        let o = self.obs_start[i];
        let a = o - i; // every earlier episode has one more observation than actions
        Episode {
            index: i,
            obs: &self.obs[o * self.obs_dim..(o + n + 1) * self.obs_dim],
            act: &self.act[a * self.act_dim..(a + n) * self.act_dim],
            rew: &self.rew[a..a + n],
            crashed: self.crashed[i],
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
        }
    }

    /// All episodes in file order.
    pub fn episodes(&self) -> impl ExactSizeIterator<Item = Episode<'_>> + '_ {
        (0..self.len()).map(|i| self.episode(i))
    }

    /// The safe group: episodes with `crashed = false`, in file order (SPEC section 1).
    pub fn safe(&self) -> impl Iterator<Item = Episode<'_>> + '_ {
        self.episodes().filter(|e| !e.crashed)
    }

    /// The unsafe group: episodes with `crashed = true`, in file order.
    pub fn unsafe_(&self) -> impl Iterator<Item = Episode<'_>> + '_ {
        self.episodes().filter(|e| e.crashed)
    }

    /// Sizes of the (safe, unsafe) groups.
    pub fn group_sizes(&self) -> (usize, usize) {
        let unsafe_ = self.crashed.iter().filter(|&&c| c).count();
        (self.len() - unsafe_, unsafe_)
    }

    /// Checks that both groups are non-empty, as a demonstration set must be.
    ///
    /// # Errors
    /// [`DefenderError::MissingGroup`] naming the file and the empty group.
    pub fn require_both_groups(&self) -> Result<()> {
        let (safe, unsafe_) = self.group_sizes();
        if safe == 0 {
            return Err(DefenderError::MissingGroup {
                path: self.source.clone(),
                group: "safe",
                crashed: false,
            });
        }
        if unsafe_ == 0 {
            return Err(DefenderError::MissingGroup {
                path: self.source.clone(),
                group: "unsafe",
                crashed: true,
            });
        }
        Ok(())
    }

    /// Checks the set against an environment's dimensions and id (`meta.env_id`, when the file
    /// names one).
    ///
    /// # Errors
    /// [`DefenderError::InvalidArray`] naming the array whose dimension differs, or the `meta`
    /// whose env id differs.
    pub fn check_env(&self, env_id: &str, obs_dim: usize, act_dim: usize) -> Result<()> {
        if self.obs_dim != obs_dim {
            return Err(bad(
                &self.source,
                "obs",
                &format!("{obs_dim} columns (the observation dimension of {env_id})"),
                format!("{} columns", self.obs_dim),
            ));
        }
        if self.act_dim != act_dim {
            return Err(bad(
                &self.source,
                "act",
                &format!("{act_dim} columns (the action dimension of {env_id})"),
                format!("{} columns", self.act_dim),
            ));
        }
        match &self.meta.env_id {
            Some(id) if id != env_id => {
                Err(bad(&self.source, "meta", &format!("env_id \"{env_id}\""), format!("env_id \"{id}\"")))
            }
            _ => Ok(()),
        }
    }

    /// The demonstrations a run uses: the first `n` episodes of each group in file order (the rule
    /// behind `--num-demos N`; files list demonstrations in the order they were made). The result
    /// keeps file order and names the same source.
    ///
    /// # Errors
    /// [`DefenderError::NotEnoughDemos`] if a group has fewer than `n`; a config error for `n = 0`.
    pub fn select_demos(&self, n: usize) -> Result<EpisodeSet> {
        if n == 0 {
            return Err(DefenderError::Config("the number of demonstrations per group must be >= 1".into()));
        }
        let (safe, unsafe_) = self.group_sizes();
        for (group, available) in [("safe", safe), ("unsafe", unsafe_)] {
            if available < n {
                return Err(DefenderError::NotEnoughDemos {
                    path: self.source.clone(),
                    setting: "num_demos",
                    group,
                    asked: n,
                    available,
                });
            }
        }
        let mut out = EpisodeSet::new(self.obs_dim, self.act_dim, self.meta.clone())?;
        out.source = self.source.clone();
        let (mut s, mut u) = (0, 0);
        for e in self.episodes() {
            let count = if e.crashed { &mut u } else { &mut s };
            if *count < n {
                *count += 1;
                out.push_episode(e.obs, e.act, e.rew, e.crashed)?;
            }
        }
        Ok(out)
    }

    /// The episodes at `order` (positions in this set, each at most once), in that order, with
    /// the same source and meta.
    ///
    /// # Errors
    /// A position out of range or given twice.
    pub fn reordered(&self, order: &[usize]) -> Result<EpisodeSet> {
        let mut seen = vec![false; self.len()];
        let mut out = EpisodeSet::new(self.obs_dim, self.act_dim, self.meta.clone())?;
        out.source = self.source.clone();
        for &i in order {
            if seen.get(i).copied() != Some(false) {
                return Err(DefenderError::Config(format!(
                    "episode {i} of {}: out of range ({} episodes) or chosen twice",
                    self.source.display(),
                    self.len()
                )));
            }
            seen[i] = true;
            let e = self.episode(i);
            out.push_episode(e.obs, e.act, e.rew, e.crashed)?;
        }
        Ok(out)
    }

    /// The lowest per-step reward over all episodes (both groups): the default `R_task`
    /// (SPEC section 5). `None` for an empty set.
    pub fn min_reward(&self) -> Option<f32> {
        self.rew.iter().copied().reduce(f32::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strategy::Mode;

    pub(crate) fn small_set() -> EpisodeSet {
        let mut set =
            EpisodeSet::new(2, 1, Meta { env_id: Some("Test-v0".into()), ..Meta::default() }).unwrap();
        set.push_episode(&[0., 0., 1., 1., 2., 2.], &[0.5, -0.5], &[1.0, 2.0], false).unwrap();
        set.push_episode(&[5., 5., 6., 6.], &[0.1], &[-3.0], true).unwrap();
        set.push_episode(&[7., 7., 8., 8., 9., 9., 10., 10.], &[0.2, 0.3, 0.4], &[0.0, 1.0, 2.0], false)
            .unwrap();
        set
    }

    #[test]
    fn episodes_groups_and_sequences() {
        let set = small_set();
        assert_eq!(set.len(), 3);
        assert_eq!(set.transitions(), 6);
        let e = set.episode(2);
        assert_eq!(e.len(), 3);
        assert_eq!(e.observation(3), &[10., 10.]);
        assert_eq!(e.action(1), &[0.3]);
        assert_eq!(e.rew, &[0.0, 1.0, 2.0]);
        assert_eq!(e.sequence(Mode::State).len(), 4 * 2);
        assert_eq!(e.sequence_len(Mode::StateAction), 3);
        assert_eq!(e.sequence(Mode::StateAction), vec![7., 7., 0.2, 8., 8., 0.3, 9., 9., 0.4]);
        assert_eq!(set.group_sizes(), (2, 1));
        assert_eq!(set.safe().map(|e| e.index).collect::<Vec<_>>(), [0, 2]);
        assert_eq!(set.unsafe_().map(|e| e.index).collect::<Vec<_>>(), [1]);
        assert_eq!(set.min_reward(), Some(-3.0));
        set.require_both_groups().unwrap();
    }

    #[test]
    fn selecting_demos_takes_the_first_n_of_each_group() {
        let set = small_set();
        let one = set.select_demos(1).unwrap();
        assert_eq!(one.len(), 2);
        assert_eq!(one.episode(0).obs, set.episode(0).obs);
        assert_eq!(one.episode(1).obs, set.episode(1).obs);
        let err = set.select_demos(2).unwrap_err().to_string();
        assert!(err.contains("num_demos asks for 2") && err.contains("unsafe group has only 1"), "{err}");
        assert!(set.select_demos(0).is_err());
        let back = set.reordered(&[2, 0]).unwrap();
        assert_eq!((back.len(), back.episode(0).obs), (2, set.episode(2).obs));
        assert!(set.reordered(&[0, 0]).is_err() && set.reordered(&[3]).is_err());
    }

    #[test]
    fn pushing_a_bad_episode_is_refused() {
        let mut set = small_set();
        assert!(set.push_episode(&[0., 0.], &[], &[], false).is_err(), "no transition");
        assert!(set.push_episode(&[0., 0., 1.], &[0.], &[0.], false).is_err(), "obs length");
        assert!(set.push_episode(&[0., 0., 1., 1.], &[0., 1.], &[0.], false).is_err(), "act length");
        let err = set.push_episode(&[0., f32::NAN, 1., 1.], &[0.], &[0.], false).unwrap_err().to_string();
        assert!(err.contains("'obs'") && err.contains("finite"), "{err}");
        assert_eq!(set.len(), 3, "unchanged");
    }

    #[test]
    fn missing_groups_and_env_mismatches_are_named() {
        let mut only_safe = EpisodeSet::new(2, 1, Meta::default()).unwrap();
        only_safe.push_episode(&[0., 0., 1., 1.], &[0.], &[0.], false).unwrap();
        let err = only_safe.require_both_groups().unwrap_err().to_string();
        assert!(err.contains("unsafe group is empty"), "{err}");
        let set = small_set();
        set.check_env("Test-v0", 2, 1).unwrap();
        assert!(set.check_env("Test-v0", 3, 1).unwrap_err().to_string().contains("'obs'"));
        assert!(set.check_env("Test-v0", 2, 2).unwrap_err().to_string().contains("'act'"));
        assert!(set.check_env("Other-v0", 2, 1).unwrap_err().to_string().contains("Other-v0"));
    }
}
