//! The offline ablation (SPEC section 7): replay recorded episodes under many strategies at once
//! and score each strategy by how much of the episodes it keeps and how many crashes it prevents.
//!
//! Work is shared three ways (docs/architecture.md, "The offline ablation shares work"): per recorded episode and
//! step, each group's stream computes the windowed costs of the windows any strategy needs once
//! (at most 8 per demonstration); the 3 aggregations of each window give the per-group values of
//! the 24 methods once; every strategy then only compares two of those numbers. Episodes run in
//! parallel (rayon), and an episode stops being replayed once every strategy has filtered it.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::cost_stream::CostStream;
use crate::demonstrations::Demonstrations;
use crate::episode_set::{Episode, EpisodeSet};
use crate::error::{DefenderError, Result};
use crate::filter::Decision;
use crate::method::{Aggregation, Method};
use crate::score::AblationRow;
use crate::scoring::{EpisodeReplay, Scoring};
use crate::strategy::{Mode, Strategy};
use crate::window::Window;

/// The ablation of a set of strategies over one demonstration set.
#[derive(Debug, Clone)]
pub struct Ablation {
    demos: Demonstrations,
    strategies: Vec<Strategy>,
    /// Windows each group's stream computes, in view order.
    safe_windows: Vec<Window>,
    unsafe_windows: Vec<Window>,
    /// Per strategy, the index of its safe / unsafe value in the per-step value tables.
    pairs: Vec<(usize, usize)>,
}

/// A demonstration of the ablation's own set left out of its group (leave-one-out,
/// [`crate::selection`]): its group's costs are aggregated without it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct HeldOut {
    /// The group: `true` for the unsafe one.
    pub crashed: bool,
    /// The demonstration's position in its group (file order).
    pub index: usize,
}

/// Progress of a running ablation, reported after each finished episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Episodes finished so far.
    pub done: usize,
    /// Episodes in total.
    pub total: usize,
    /// Transitions of the episode that just finished.
    pub episode_len: usize,
}

impl Ablation {
    /// An ablation of `strategies` (e.g. `Strategy::all()`) with prepared demonstrations; the
    /// mode is the demonstrations' mode. Duplicates are kept once, in first-seen order.
    ///
    /// # Errors
    /// An empty list of strategies; a DTW error for invalid views (cannot happen).
    pub fn new(demos: &Demonstrations, strategies: &[Strategy]) -> Result<Self> {
        let mut list: Vec<Strategy> = Vec::with_capacity(strategies.len());
        for s in strategies {
            if !list.contains(s) {
                list.push(*s);
            }
        }
        if list.is_empty() {
            return Err(DefenderError::Config("the ablation needs at least one strategy".into()));
        }
        let windows_of = |pick: fn(&Strategy) -> Method| -> Vec<Window> {
            Window::ALL.into_iter().filter(|w| list.iter().any(|s| pick(s).window == *w)).collect()
        };
        let safe_windows = windows_of(|s| s.safe);
        let unsafe_windows = windows_of(|s| s.unsafe_);
        let slot = |windows: &[Window], m: Method| {
            let w = windows.iter().position(|&w| w == m.window).unwrap_or(0);
            w * Aggregation::ALL.len() + m.aggregation.index()
        };
        let pairs =
            list.iter().map(|s| (slot(&safe_windows, s.safe), slot(&unsafe_windows, s.unsafe_))).collect();
        Ok(Self { demos: demos.clone(), strategies: list, safe_windows, unsafe_windows, pairs })
    }

    /// The strategies, in the order results use.
    pub fn strategies(&self) -> &[Strategy] {
        &self.strategies
    }

    /// The trajectory mode.
    pub fn mode(&self) -> Mode {
        self.demos.mode()
    }

    fn streams(&self) -> Result<(CostStream, CostStream)> {
        Ok((
            self.demos.cost_stream(false, &self.safe_windows)?,
            self.demos.cost_stream(true, &self.unsafe_windows)?,
        ))
    }

    /// Replays one recorded episode under every strategy (SPEC section 7).
    ///
    /// # Errors
    /// The episode's dimensions differ from the demonstrations'.
    pub fn replay(&self, episode: Episode<'_>) -> Result<EpisodeReplay> {
        let (mut safe, mut unsafe_) = self.streams()?;
        self.replay_with(episode, None, &mut safe, &mut unsafe_, &mut Vec::new())
    }

    fn replay_with(
        &self,
        episode: Episode<'_>,
        held_out: Option<HeldOut>,
        safe: &mut CostStream,
        unsafe_: &mut CostStream,
        element: &mut Vec<f32>,
    ) -> Result<EpisodeReplay> {
        if episode.obs_dim != self.demos.obs_dim() || episode.act_dim != self.demos.act_dim() {
            return Err(DefenderError::Mismatch {
                what: format!(
                    "episode {} dimensions (obs_dim, act_dim) vs the demonstrations'",
                    episode.index
                ),
                expected: format!("({}, {})", self.demos.obs_dim(), self.demos.act_dim()),
                got: format!("({}, {})", episode.obs_dim, episode.act_dim),
            });
        }
        safe.reset();
        unsafe_.reset();
        let ties = self.demos.options().ties;
        let mut first: Vec<Option<usize>> = vec![None; self.strategies.len()];
        let mut open = first.len();
        let mut safe_values = vec![f64::NAN; self.safe_windows.len() * 3];
        let mut unsafe_values = vec![f64::NAN; self.unsafe_windows.len() * 3];
        // Decisions are made at t = 0 .. T_e - 1 from s_t (and a_t): never from the final observation.
        for t in 0..episode.len() {
            self.demos.element_into(episode.observation(t).iter().copied(), episode.action(t), element);
            safe.push(element)?;
            unsafe_.push(element)?;
            for (crashed, stream, values) in
                [(false, &*safe, &mut safe_values), (true, &*unsafe_, &mut unsafe_values)]
            {
                let skip = held_out.filter(|h| h.crashed == crashed).map(|h| h.index);
                for (v, chunk) in values.chunks_exact_mut(3).enumerate() {
                    chunk.copy_from_slice(&Aggregation::apply_all_except(stream.costs(v), skip));
                }
            }
            for (k, &(s, u)) in first.iter_mut().zip(&self.pairs) {
                if k.is_none() && Decision::with_ties(safe_values[s], unsafe_values[u], ties).filtered {
                    *k = Some(t);
                    open -= 1;
                }
            }
            if open == 0 {
                break;
            }
        }
        Ok(EpisodeReplay { len: episode.len(), crashed: episode.crashed, first_filtered: first })
    }

    /// Replays every episode of `episodes` (in parallel on rayon's pool) and scores every strategy
    /// (SPEC section 7). `progress` is called after each finished episode, from worker threads.
    /// Rows come ranked: score highest first, ties by strategy name.
    ///
    /// # Errors
    /// An empty episode set, or dimensions that differ from the demonstrations'.
    pub fn run(
        &self,
        episodes: &EpisodeSet,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Vec<AblationRow>> {
        self.run_scored(episodes, Scoring::Spec, progress)
    }

    /// [`Ablation::run`] with the score `scoring` computes (SPEC's, or the authors').
    ///
    /// # Errors
    /// As [`Ablation::run`].
    pub fn run_scored(
        &self,
        episodes: &EpisodeSet,
        scoring: Scoring,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Vec<AblationRow>> {
        let replays = self.replay_all(episodes, progress)?;
        Ok(crate::score::rank(scoring.rows(&self.strategies, self.mode(), &replays)))
    }

    /// Replays every episode (in parallel), in file order.
    ///
    /// # Errors
    /// As [`Ablation::run`].
    pub fn replay_all(
        &self,
        episodes: &EpisodeSet,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Vec<EpisodeReplay>> {
        if episodes.is_empty() {
            return Err(DefenderError::InvalidArray {
                path: episodes.source().to_owned(),
                array: "ep_len",
                expected: "at least one recorded episode".into(),
                got: "none".into(),
            });
        }
        self.replay_parallel(episodes, |_| None, progress)
    }

    /// Replays every episode of `set` in parallel (one pair of streams per worker thread), each
    /// against the demonstrations without the one `held_out(i)` names, reporting progress; the
    /// replays come back in file order.
    fn replay_parallel(
        &self,
        set: &EpisodeSet,
        held_out: impl Fn(usize) -> Option<HeldOut> + Sync,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Vec<EpisodeReplay>> {
        let total = set.len();
        let done = AtomicUsize::new(0);
        (0..total)
            .into_par_iter()
            .map_init(
                || (self.streams(), Vec::new()),
                |(streams, element), i| {
                    let (safe, unsafe_) =
                        streams.as_mut().map_err(|e| DefenderError::Config(e.to_string()))?;
                    let replay = self.replay_with(set.episode(i), held_out(i), safe, unsafe_, element)?;
                    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(Progress { done: d, total, episode_len: replay.len });
                    Ok(replay)
                },
            )
            .collect()
    }
}

impl Ablation {
    /// Leave-one-out over the ablation's own demonstrations: every episode of `set` (the set the
    /// demonstrations were prepared from) is replayed against the others of its group and all of
    /// the other group, in parallel, and comes back in file order with its [`HeldOut`] position.
    /// Equal bit for bit to a replay against demonstrations prepared without it (with
    /// [`crate::Scaling::None`]; z-score scaling stays fitted on the whole set).
    ///
    /// # Errors
    /// A set whose groups do not match the demonstrations' (sizes or lengths).
    pub(crate) fn replay_held_out(
        &self,
        set: &EpisodeSet,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Vec<(HeldOut, EpisodeReplay)>> {
        let mut positions = Vec::with_capacity(set.len());
        let (mut safe, mut unsafe_) = (0, 0);
        for e in set.episodes() {
            let (count, refs) =
                if e.crashed { (&mut unsafe_, self.demos.unsafe_()) } else { (&mut safe, self.demos.safe()) };
            if refs.lengths().get(*count) != Some(&self.demos.sequence_len(&e)) {
                return Err(DefenderError::Mismatch {
                    what: format!(
                        "episode {} of {} vs the prepared demonstrations",
                        e.index,
                        set.source().display()
                    ),
                    expected: "the set the demonstrations were prepared from".into(),
                    got: "another set".into(),
                });
            }
            positions.push(HeldOut { crashed: e.crashed, index: *count });
            *count += 1;
        }
        if (safe, unsafe_) != (self.demos.safe().len(), self.demos.unsafe_().len()) {
            return Err(DefenderError::Mismatch {
                what: format!("group sizes of {} vs the prepared demonstrations", set.source().display()),
                expected: format!("({}, {})", self.demos.safe().len(), self.demos.unsafe_().len()),
                got: format!("({safe}, {unsafe_})"),
            });
        }
        let replays = self.replay_parallel(set, |i| Some(positions[i]), progress)?;
        Ok(positions.into_iter().zip(replays).collect())
    }
}

/// Runs the ablation of `strategies` (all 576 when `None`) in `mode` over a recorded episode set.
///
/// # Errors
/// As [`Demonstrations::new`], [`Ablation::new`] and [`Ablation::run`].
pub fn ablate(
    demos: &EpisodeSet,
    episodes: &EpisodeSet,
    strategies: Option<&[Strategy]>,
    mode: Mode,
    options: crate::demonstrations::CostOptions,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Vec<AblationRow>> {
    ablate_scored(demos, episodes, strategies, mode, options, Scoring::Spec, progress)
}

/// [`ablate`] with the score `scoring` computes.
///
/// # Errors
/// As [`ablate`].
pub fn ablate_scored(
    demos: &EpisodeSet,
    episodes: &EpisodeSet,
    strategies: Option<&[Strategy]>,
    mode: Mode,
    options: crate::demonstrations::CostOptions,
    scoring: Scoring,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Vec<AblationRow>> {
    // The recorded episodes must come from the demonstrations' environment.
    let env_id =
        demos.meta().env_id.as_deref().or(episodes.meta().env_id.as_deref()).unwrap_or("the demonstrations");
    episodes.check_env(env_id, demos.obs_dim(), demos.act_dim())?;
    let prepared = Demonstrations::new(demos, mode, options)?;
    let all: Vec<Strategy>;
    let list = match strategies {
        Some(list) => list,
        None => {
            all = Strategy::all().collect();
            &all
        }
    };
    Ablation::new(&prepared, list)?.run_scored(episodes, scoring, progress)
}
