//! A demonstration set made ready for alignment: the sequences of both groups (SPEC section 1) as
//! `defender-dtw` reference sets, and the optional feature scaling (SPEC section 2).

use std::sync::Arc;

use defender_dtw::References;

use crate::cost::Elements;
pub use crate::cost::{CostOptions, Scaling};
use crate::cost_stream::{CostStream, Recompute};
use crate::window::Window;

use crate::episode_set::{Episode, EpisodeSet};
use crate::error::{DefenderError, Result};
use crate::strategy::Mode;

/// Per-feature affine map `(v - mean) * inv_std`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scaler {
    mean: Vec<f32>,
    inv_std: Vec<f32>,
}

impl Scaler {
    fn fit(seqs: &[Vec<f32>], dim: usize) -> Self {
        let mut sum = vec![0.0f64; dim];
        let mut sq = vec![0.0f64; dim];
        let mut count = 0usize;
        for s in seqs {
            for row in s.chunks_exact(dim) {
                count += 1;
                for (k, &v) in row.iter().enumerate() {
                    sum[k] += f64::from(v);
                    sq[k] += f64::from(v) * f64::from(v);
                }
            }
        }
        let n = count.max(1) as f64;
        let mean: Vec<f64> = sum.iter().map(|s| s / n).collect();
        let inv_std = sq
            .iter()
            .zip(&mean)
            .map(|(q, m)| {
                let std = (q / n - m * m).max(0.0).sqrt();
                if std < 1e-6 { 1.0 } else { (1.0 / std) as f32 }
            })
            .collect();
        Self { mean: mean.iter().map(|&m| m as f32).collect(), inv_std }
    }

    pub(crate) fn apply(&self, row: &mut [f32]) {
        for ((v, m), s) in row.iter_mut().zip(&self.mean).zip(&self.inv_std) {
            *v = (*v - m) * s;
        }
    }
}

/// Both groups of a demonstration set, ready to be aligned with trajectories of one mode.
/// Cloning is cheap (the reference storage is shared).
#[derive(Debug, Clone)]
pub struct Demonstrations {
    mode: Mode,
    obs_dim: usize,
    act_dim: usize,
    options: CostOptions,
    scaler: Option<Scaler>,
    safe: References,
    unsafe_: References,
    /// The (scaled) sequences of each group, row-major, for the costs that are recomputed per
    /// step from the capped trajectory (`CostOptions::is_incremental` false).
    safe_seqs: Arc<Vec<Vec<f32>>>,
    unsafe_seqs: Arc<Vec<Vec<f32>>>,
    min_reward: f32,
    /// The longest safe demonstration, in transitions: the horizon the set was made with.
    safe_horizon: usize,
}

impl Demonstrations {
    /// Prepares `set` (which must have both groups) for trajectories of `mode`.
    ///
    /// # Errors
    /// [`DefenderError::MissingGroup`] if a group is empty; a DTW error for unusable sequences.
    pub fn new(set: &EpisodeSet, mode: Mode, options: CostOptions) -> Result<Self> {
        set.require_both_groups()?;
        options.validate()?;
        let dim = mode.element_dim(set.obs_dim(), set.act_dim());
        let sequence = |e| sequence(e, mode, options);
        let mut safe: Vec<Vec<f32>> = set.safe().map(sequence).collect();
        let mut unsafe_: Vec<Vec<f32>> = set.unsafe_().map(sequence).collect();
        let scaler = match options.scaling {
            Scaling::None => None,
            Scaling::Zscore => {
                let all: Vec<Vec<f32>> = safe.iter().chain(&unsafe_).cloned().collect();
                Some(Scaler::fit(&all, dim))
            }
        };
        if let Some(sc) = &scaler {
            for s in safe.iter_mut().chain(unsafe_.iter_mut()) {
                s.chunks_exact_mut(dim).for_each(|row| sc.apply(row));
            }
        }
        let min_reward = set.min_reward().ok_or_else(|| DefenderError::MissingGroup {
            path: set.source().to_owned(),
            group: "safe",
            crashed: false,
        })?;
        Ok(Self {
            mode,
            obs_dim: set.obs_dim(),
            act_dim: set.act_dim(),
            options,
            scaler,
            safe: references(dim, &safe)?,
            unsafe_: references(dim, &unsafe_)?,
            safe_seqs: Arc::new(safe),
            unsafe_seqs: Arc::new(unsafe_),
            min_reward,
            safe_horizon: set.safe().map(|e| e.len()).max().unwrap_or(0),
        })
    }

    /// The trajectory mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// Dimension of one trajectory element.
    pub fn element_dim(&self) -> usize {
        self.mode.element_dim(self.obs_dim, self.act_dim)
    }

    /// The cost options.
    pub fn options(&self) -> CostOptions {
        self.options
    }

    /// The safe group's sequences as a reference set.
    pub fn safe(&self) -> &References {
        &self.safe
    }

    /// The unsafe group's sequences as a reference set.
    pub fn unsafe_(&self) -> &References {
        &self.unsafe_
    }

    /// A stream of the costs of one group (`crashed`: the unsafe one) for `windows`, under the
    /// set's cost options: incremental for SPEC's cost, recomputed per step otherwise.
    ///
    /// # Errors
    /// A DTW error for an invalid view (cannot happen for the SPEC's windows).
    pub fn cost_stream(&self, crashed: bool, windows: &[Window]) -> Result<CostStream> {
        if self.options.is_incremental() {
            let views: Vec<_> = windows.iter().map(|w| w.view()).collect();
            let refs = if crashed { &self.unsafe_ } else { &self.safe };
            return Ok(CostStream::Exact(refs.stream(&views)?));
        }
        let seqs = if crashed { &self.unsafe_seqs } else { &self.safe_seqs };
        Ok(CostStream::Recompute(Recompute::new(Arc::clone(seqs), self.element_dim(), windows, self.options)))
    }

    /// The longest safe demonstration of the set, in transitions: the horizon it was made with (a
    /// safe demonstration reached the task's horizon; joined episodes leave it unchanged).
    pub fn safe_horizon(&self) -> usize {
        self.safe_horizon
    }

    /// The lowest per-step reward of the set (both groups): the default `R_task`.
    pub fn min_reward(&self) -> f32 {
        self.min_reward
    }

    /// The number of elements of `e`'s sequence as these demonstrations prepare it (SPEC section
    /// 1, or one element per transition under the authors' `elements`).
    pub(crate) fn sequence_len(&self, e: &Episode<'_>) -> usize {
        if self.options.elements == Elements::PerTransition && self.mode == Mode::State {
            e.len()
        } else {
            e.sequence_len(self.mode)
        }
    }

    /// These demonstrations with `safe` and `unsafe_` episodes appended to their groups, prepared
    /// as the set's own: same mode, cost options and scaling (the scaler stays the one fitted on
    /// the set, so costs keep their scale as groups grow); `R_task` stays the set's.
    ///
    /// # Errors
    /// An episode of other dimensions ([`DefenderError::Mismatch`]) or a DTW error.
    pub fn joined<'a>(
        &self,
        safe: impl IntoIterator<Item = Episode<'a>>,
        unsafe_: impl IntoIterator<Item = Episode<'a>>,
    ) -> Result<Self> {
        let dim = self.element_dim();
        let prepare = |seqs: &Arc<Vec<Vec<f32>>>, extra: &mut dyn Iterator<Item = Episode<'a>>| {
            let mut all = Vec::clone(seqs);
            for e in extra {
                if (e.obs_dim, e.act_dim) != (self.obs_dim, self.act_dim) {
                    return Err(DefenderError::Mismatch {
                        what: "episode joining the demonstrations (obs, act dimensions)".into(),
                        expected: format!("({}, {})", self.obs_dim, self.act_dim),
                        got: format!("({}, {})", e.obs_dim, e.act_dim),
                    });
                }
                let mut s = sequence(e, self.mode, self.options);
                if let Some(sc) = &self.scaler {
                    s.chunks_exact_mut(dim).for_each(|row| sc.apply(row));
                }
                all.push(s);
            }
            Ok(all)
        };
        let safe = prepare(&self.safe_seqs, &mut safe.into_iter())?;
        let unsafe_ = prepare(&self.unsafe_seqs, &mut unsafe_.into_iter())?;
        Ok(Self {
            safe: references(dim, &safe)?,
            unsafe_: references(dim, &unsafe_)?,
            safe_seqs: Arc::new(safe),
            unsafe_seqs: Arc::new(unsafe_),
            scaler: self.scaler.clone(),
            ..*self
        })
    }

    /// Writes the trajectory element of (`obs`, `act`) for this mode into `out` (cleared first),
    /// scaled like the demonstrations. Lengths are the caller's to check.
    pub(crate) fn element_into(&self, obs: impl IntoIterator<Item = f32>, act: &[f32], out: &mut Vec<f32>) {
        out.clear();
        out.extend(obs);
        if self.mode == Mode::StateAction {
            out.extend_from_slice(act);
        }
        if let Some(sc) = &self.scaler {
            sc.apply(out);
        }
    }
}

/// An episode's sequence under `mode` and `options.elements` (SPEC section 1, or one element per
/// transition, which drops the final observation in state mode).
fn sequence(e: Episode<'_>, mode: Mode, options: CostOptions) -> Vec<f32> {
    let mut s = e.sequence(mode);
    if options.elements == Elements::PerTransition && mode == Mode::State {
        s.truncate(e.len() * mode.element_dim(e.obs_dim, e.act_dim));
    }
    s
}

fn references(dim: usize, seqs: &[Vec<f32>]) -> Result<References> {
    let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
    Ok(References::new(dim, &slices)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode_set::Meta;

    #[test]
    fn groups_become_reference_sets_per_mode() {
        let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        set.push_episode(&[0., 1., 2.], &[5., 6.], &[1., 1.], false).unwrap();
        set.push_episode(&[3., 4.], &[7.], &[-2.], true).unwrap();
        let d = Demonstrations::new(&set, Mode::State, CostOptions::default()).unwrap();
        assert_eq!(d.safe().lengths(), &[3]);
        assert_eq!(d.unsafe_().lengths(), &[2]);
        assert_eq!(d.min_reward(), -2.0);
        let d = Demonstrations::new(&set, Mode::StateAction, CostOptions::default()).unwrap();
        assert_eq!((d.safe().lengths(), d.element_dim()), (&[2usize][..], 2));
        let mut e = Vec::new();
        d.element_into([1.0], &[2.0], &mut e);
        assert_eq!(e, [1.0, 2.0]);
    }

    #[test]
    fn zscore_scaling_is_fitted_on_both_groups() {
        let mut set = EpisodeSet::new(1, 1, Meta::default()).unwrap();
        set.push_episode(&[0., 2.], &[0.], &[0.], false).unwrap();
        set.push_episode(&[4., 6.], &[0.], &[0.], true).unwrap();
        let opts = CostOptions::with_scaling(Scaling::Zscore);
        let d = Demonstrations::new(&set, Mode::State, opts).unwrap();
        // mean 3, std sqrt(5)
        let mut e = Vec::new();
        d.element_into([3.0 + 5f32.sqrt()], &[0.0], &mut e);
        assert!((e[0] - 1.0).abs() < 1e-6, "{e:?}");
        let json = serde_json::to_string(&opts).unwrap();
        assert!(json.starts_with(r#"{"scaling":"zscore","dtw":"exact""#), "{json}");
    }
}
