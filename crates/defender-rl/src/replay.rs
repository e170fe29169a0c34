//! The replay buffer: a preallocated ring of transitions, sampled uniformly into a named batch.
//!
//! As Stable-Baselines3's `ReplayBuffer`: `pos` is where the next transition goes, `full` says
//! whether the ring has wrapped. `terminated` is stored apart from `truncated`: only
//! `terminated` stops bootstrapping (a time limit is not an absorbing state). Nothing is
//! allocated per transition or per batch.

use std::io::{Read, Write};
use std::path::Path;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::error::{RlError, check_vector};

/// One transition, as the trainer hands it to an agent.
#[derive(Debug, Clone, Copy)]
pub struct Transition<'a> {
    /// Observation before the step.
    pub obs: &'a [f64],
    /// The action taken, in the agent's normalised space [-1, 1] (before rescaling to the bounds).
    pub action: &'a [f32],
    /// Reward of the step.
    pub reward: f64,
    /// Cost of the step ([`crate::Step::cost`]).
    pub cost: f64,
    /// Observation after the step (the final observation when the episode ended).
    pub next_obs: &'a [f64],
    /// The episode reached an absorbing state: the target must not bootstrap from `next_obs`.
    pub terminated: bool,
    /// The episode was cut by the time limit: the target bootstraps as usual.
    pub truncated: bool,
}

/// A sampled mini-batch, row-major (`batch_size` rows). Allocated once, refilled by
/// [`ReplayBuffer::sample_into`].
#[derive(Debug, Clone)]
pub struct Batch {
    /// Rows in the batch.
    pub size: usize,
    /// Observations, `size x obs_dim`.
    pub obs: Vec<f32>,
    /// Actions in [-1, 1], `size x act_dim`.
    pub actions: Vec<f32>,
    /// Rewards, `size`.
    pub rewards: Vec<f32>,
    /// Costs, `size` (what a cost critic learns: Lagrangian SAC, Recovery RL's safety critic).
    pub costs: Vec<f32>,
    /// Next observations, `size x obs_dim`.
    pub next_obs: Vec<f32>,
    /// 1.0 where the transition terminated (no bootstrap), else 0.0, `size`.
    pub terminated: Vec<f32>,
    /// 1.0 where the row is a transition of a safe demonstration stored for behaviour cloning
    /// ([`ReplayBuffer::push_demonstration`]), else 0.0, `size`.
    pub bc: Vec<f32>,
}

impl Batch {
    /// A zeroed batch of `size` rows.
    pub fn new(size: usize, obs_dim: usize, act_dim: usize) -> Self {
        Self {
            size,
            obs: vec![0.0; size * obs_dim],
            actions: vec![0.0; size * act_dim],
            rewards: vec![0.0; size],
            costs: vec![0.0; size],
            next_obs: vec![0.0; size * obs_dim],
            terminated: vec![0.0; size],
            bc: vec![0.0; size],
        }
    }
}

/// A fixed-capacity ring buffer of transitions in `f32`.
#[derive(Debug, Clone)]
pub struct ReplayBuffer {
    obs_dim: usize,
    act_dim: usize,
    capacity: usize,
    pos: usize,
    full: bool,
    obs: Vec<f32>,
    next_obs: Vec<f32>,
    actions: Vec<f32>,
    rewards: Vec<f32>,
    costs: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    /// The transition belongs to a safe demonstration to clone (saved as bit 2 of the flags, so
    /// files written before it existed read as no demonstrations).
    bc: Vec<bool>,
}

/// Magic and version at the head of a saved buffer: version 2 adds the costs after the flags.
const MAGIC: &[u8; 8] = b"DFRPLB02";
/// Version 1, before costs: read with zero costs (no agent of that time read them, so a run
/// resumed from such a buffer continues exactly as it began).
const MAGIC_V1: &[u8; 8] = b"DFRPLB01";

impl ReplayBuffer {
    /// An empty buffer holding up to `capacity` transitions (all memory reserved now; the OS
    /// maps the zeroed pages lazily).
    ///
    /// # Errors
    /// [`RlError::Config`] if `capacity` or a dimension is zero, or the buffer does not fit in
    /// memory.
    pub fn new(capacity: usize, obs_dim: usize, act_dim: usize) -> Result<Self, RlError> {
        if capacity == 0 {
            return Err(RlError::Config { field: "buffer_size", value: "0".into(), expected: "at least 1" });
        }
        if obs_dim == 0 || act_dim == 0 {
            return Err(RlError::Config {
                field: "obs_dim/act_dim",
                value: format!("{obs_dim}/{act_dim}"),
                expected: "both at least 1",
            });
        }
        let too_big = |what: &str| RlError::Config {
            field: "buffer_size",
            value: format!("{capacity} ({what} of {capacity} x {obs_dim} observations cannot be allocated)"),
            expected: "a replay buffer that fits in this machine's memory",
        };
        let floats = |n: Option<usize>, what: &str| n.and_then(zeroed::<f32>).ok_or_else(|| too_big(what));
        Ok(Self {
            obs_dim,
            act_dim,
            capacity,
            pos: 0,
            full: false,
            obs: floats(capacity.checked_mul(obs_dim), "the observations")?,
            next_obs: floats(capacity.checked_mul(obs_dim), "the next observations")?,
            actions: floats(capacity.checked_mul(act_dim), "the actions")?,
            rewards: floats(Some(capacity), "the rewards")?,
            costs: floats(Some(capacity), "the costs")?,
            terminated: zeroed::<bool>(capacity).ok_or_else(|| too_big("the flags"))?,
            truncated: zeroed::<bool>(capacity).ok_or_else(|| too_big("the flags"))?,
            bc: zeroed::<bool>(capacity).ok_or_else(|| too_big("the flags"))?,
        })
    }

    /// Transitions stored (at most the capacity).
    pub fn len(&self) -> usize {
        if self.full { self.capacity } else { self.pos }
    }

    /// Whether no transition is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The capacity.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Observation dimension.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action dimension.
    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// Stores a transition, overwriting the oldest one when full.
    ///
    /// # Errors
    /// A vector has the wrong length or a non-finite value.
    pub fn push(&mut self, t: &Transition<'_>) -> Result<(), RlError> {
        self.push_flagged(t, false)
    }

    /// Stores a demonstration's transition; `bc`: a behaviour-cloning term may pull the policy
    /// towards its action (a safe demonstration's).
    ///
    /// # Errors
    /// As [`ReplayBuffer::push`].
    pub fn push_demonstration(&mut self, t: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        self.push_flagged(t, bc)
    }

    /// Transitions stored with the behaviour-cloning flag.
    pub fn bc_count(&self) -> usize {
        self.bc[..self.len()].iter().filter(|&&b| b).count()
    }

    fn push_flagged(&mut self, t: &Transition<'_>, bc: bool) -> Result<(), RlError> {
        check_vector("replay obs", t.obs, self.obs_dim)?;
        check_vector("replay next_obs", t.next_obs, self.obs_dim)?;
        if t.action.len() != self.act_dim {
            return Err(crate::EnvError::LengthMismatch {
                name: "replay action".into(),
                expected: self.act_dim,
                got: t.action.len(),
            }
            .into());
        }
        let (o, a) = (self.pos * self.obs_dim, self.pos * self.act_dim);
        for (dst, &src) in self.obs[o..o + self.obs_dim].iter_mut().zip(t.obs) {
            *dst = src as f32;
        }
        for (dst, &src) in self.next_obs[o..o + self.obs_dim].iter_mut().zip(t.next_obs) {
            *dst = src as f32;
        }
        self.actions[a..a + self.act_dim].copy_from_slice(t.action);
        self.rewards[self.pos] = t.reward as f32;
        self.costs[self.pos] = t.cost as f32;
        self.terminated[self.pos] = t.terminated;
        self.truncated[self.pos] = t.truncated;
        self.bc[self.pos] = bc;
        self.pos += 1;
        if self.pos == self.capacity {
            self.full = true;
            self.pos = 0;
        }
        Ok(())
    }

    /// Fills `batch` with `batch.size` transitions drawn uniformly with replacement (as SB3).
    ///
    /// # Errors
    /// [`RlError::Config`] if the buffer is empty or the batch was made for other dimensions.
    pub fn sample_into(&self, rng: &mut ChaCha8Rng, batch: &mut Batch) -> Result<(), RlError> {
        self.check_batch(batch)?;
        let n = self.len();
        for row in 0..batch.size {
            let i = rng.random_range(0..n);
            self.copy_row(i, batch, row);
        }
        Ok(())
    }

    /// The checks of [`ReplayBuffer::sample_into`]: something stored, a batch of this shape.
    pub(crate) fn check_batch(&self, batch: &Batch) -> Result<(), RlError> {
        if self.is_empty() {
            return Err(RlError::Config {
                field: "learning_starts",
                value: "0 transitions".into(),
                expected: "at least one stored transition before sampling",
            });
        }
        if batch.obs.len() != batch.size * self.obs_dim || batch.actions.len() != batch.size * self.act_dim {
            return Err(RlError::Config {
                field: "batch",
                value: format!("{} rows", batch.size),
                expected: "a batch made with the buffer's obs_dim and act_dim",
            });
        }
        Ok(())
    }

    /// Copies stored transition `i` into row `row` of `batch` (whose shape the caller checked,
    /// as [`ReplayBuffer::sample_into`] does).
    pub(crate) fn copy_row(&self, i: usize, batch: &mut Batch, row: usize) {
        let (od, ad) = (self.obs_dim, self.act_dim);
        batch.obs[row * od..(row + 1) * od].copy_from_slice(&self.obs[i * od..(i + 1) * od]);
        batch.next_obs[row * od..(row + 1) * od].copy_from_slice(&self.next_obs[i * od..(i + 1) * od]);
        batch.actions[row * ad..(row + 1) * ad].copy_from_slice(&self.actions[i * ad..(i + 1) * ad]);
        batch.rewards[row] = self.rewards[i];
        batch.costs[row] = self.costs[i];
        // Only `terminated` masks the bootstrap; `truncated` transitions bootstrap as usual.
        batch.terminated[row] = if self.terminated[i] { 1.0 } else { 0.0 };
        batch.bc[row] = if self.bc[i] { 1.0 } else { 0.0 };
    }

    /// The slot the next push writes (the oldest transition's once the buffer is full).
    pub(crate) fn next_slot(&self) -> usize {
        self.pos
    }

    /// The cost of stored transition `i`.
    pub(crate) fn cost(&self, i: usize) -> f32 {
        self.costs[i]
    }

    /// Writes the buffer (dimensions, position, and the stored rows only) to `path`.
    ///
    /// # Errors
    /// [`RlError::Io`].
    pub fn save(&self, path: &Path) -> Result<(), RlError> {
        let file = std::fs::File::create(path).map_err(|e| RlError::io(path, e))?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
        let n = self.len();
        let mut write = |bytes: &[u8]| w.write_all(bytes).map_err(|e| RlError::io(path, e));
        write(MAGIC)?;
        for v in [self.obs_dim, self.act_dim, self.capacity, self.pos, usize::from(self.full), n] {
            write(&(v as u64).to_le_bytes())?;
        }
        for (values, dim) in
            [(&self.obs, self.obs_dim), (&self.next_obs, self.obs_dim), (&self.actions, self.act_dim)]
        {
            for v in &values[..n * dim] {
                write(&v.to_le_bytes())?;
            }
        }
        for v in &self.rewards[..n] {
            write(&v.to_le_bytes())?;
        }
        let flags: Vec<u8> = (0..n)
            .map(|i| {
                u8::from(self.terminated[i])
                    | (u8::from(self.truncated[i]) << 1)
                    | (u8::from(self.bc[i]) << 2)
            })
            .collect();
        write(&flags)?;
        for v in &self.costs[..n] {
            write(&v.to_le_bytes())?;
        }
        w.flush().map_err(|e| RlError::io(path, e))
    }

    /// Reads a buffer written by [`ReplayBuffer::save`] into this one (same dimensions and
    /// capacity).
    ///
    /// # Errors
    /// [`RlError::Io`], or [`RlError::Checkpoint`] if the file is not a buffer of this shape.
    pub fn load(&mut self, path: &Path) -> Result<(), RlError> {
        let file = std::fs::File::open(path).map_err(|e| RlError::io(path, e))?;
        let mut r = std::io::BufReader::with_capacity(1 << 20, file);
        let mut magic = [0u8; 8];
        r.read_exact(&mut magic).map_err(|e| RlError::io(path, e))?;
        let v1 = &magic == MAGIC_V1;
        if &magic != MAGIC && !v1 {
            return Err(RlError::checkpoint(path, "not a replay buffer file (bad magic)"));
        }
        let mut header = [0u64; 6];
        for h in &mut header {
            let mut b = [0u8; 8];
            r.read_exact(&mut b).map_err(|e| RlError::io(path, e))?;
            *h = u64::from_le_bytes(b);
        }
        let [obs_dim, act_dim, capacity, pos, full, n] = header.map(|v| v as usize);
        if (obs_dim, act_dim, capacity) != (self.obs_dim, self.act_dim, self.capacity) {
            return Err(RlError::checkpoint(
                path,
                format!(
                    "buffer of obs_dim {obs_dim}, act_dim {act_dim}, capacity {capacity}; expected {}, {}, {}",
                    self.obs_dim, self.act_dim, self.capacity
                ),
            ));
        }
        let expected_n = if full == 1 { capacity } else { pos };
        if n != expected_n || pos >= capacity || full > 1 {
            return Err(RlError::checkpoint(
                path,
                format!("inconsistent header: pos {pos}, full {full}, len {n}"),
            ));
        }
        let read_f32 = |r: &mut std::io::BufReader<std::fs::File>, dst: &mut [f32]| -> Result<(), RlError> {
            let mut bytes = vec![0u8; dst.len() * 4];
            r.read_exact(&mut bytes).map_err(|e| RlError::io(path, e))?;
            for (d, c) in dst.iter_mut().zip(bytes.chunks_exact(4)) {
                *d = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            }
            Ok(())
        };
        read_f32(&mut r, &mut self.obs[..n * obs_dim])?;
        read_f32(&mut r, &mut self.next_obs[..n * obs_dim])?;
        read_f32(&mut r, &mut self.actions[..n * act_dim])?;
        read_f32(&mut r, &mut self.rewards[..n])?;
        let mut flags = vec![0u8; n];
        r.read_exact(&mut flags).map_err(|e| RlError::io(path, e))?;
        for (i, f) in flags.iter().enumerate() {
            self.terminated[i] = f & 1 != 0;
            self.truncated[i] = f & 2 != 0;
            self.bc[i] = f & 4 != 0;
        }
        if v1 {
            self.costs[..n].fill(0.0);
        } else {
            read_f32(&mut r, &mut self.costs[..n])?;
        }
        self.pos = pos;
        self.full = full == 1;
        Ok(())
    }
}

/// A vector of `n` zeroes, or `None` if the memory cannot be had (instead of aborting the
/// process, as `vec![0.0; n]` does). Like `vec!`, it asks the allocator for zeroed memory, which
/// the OS maps lazily.
fn zeroed<T: Zeroable>(n: usize) -> Option<Vec<T>> {
    if n == 0 {
        return Some(Vec::new());
    }
    let layout = std::alloc::Layout::array::<T>(n).ok()?;
    // SAFETY: `layout` has a non-zero size; a non-null result is a fresh allocation of `n`
    // values of `T` whose all-zero bit pattern is a valid value (the `Zeroable` contract), made
    // with the global allocator and the layout `Vec` uses for a capacity of `n`.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout).cast::<T>();
        if ptr.is_null() { None } else { Some(Vec::from_raw_parts(ptr, n, n)) }
    }
}

/// Types whose all-zero bit pattern is a valid value (`0.0`, `false`).
trait Zeroable: Copy {}
impl Zeroable for f32 {}
impl Zeroable for bool {}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn t<'a>(obs: &'a [f64], act: &'a [f32], next: &'a [f64], term: bool) -> Transition<'a> {
        Transition {
            obs,
            action: act,
            reward: obs[0],
            cost: f64::from(u8::from(term)),
            next_obs: next,
            terminated: term,
            truncated: !term,
        }
    }

    #[test]
    fn ring_wraps_and_overwrites_the_oldest() {
        let mut buf = ReplayBuffer::new(3, 1, 1).unwrap();
        for i in 0..5 {
            let x = f64::from(i);
            buf.push(&t(&[x], &[0.5], &[x + 1.0], i % 2 == 0)).unwrap();
        }
        assert_eq!(buf.len(), 3);
        // Slots hold transitions 3, 4, 2.
        assert_eq!(buf.obs, vec![3.0, 4.0, 2.0]);
        assert_eq!(buf.terminated, vec![false, true, true]);
        assert_eq!(buf.truncated, vec![true, false, false]);
    }

    #[test]
    fn batch_rows_are_whole_transitions_and_mask_only_terminated() {
        let mut buf = ReplayBuffer::new(100, 2, 1).unwrap();
        for i in 0..50 {
            let x = f64::from(i);
            buf.push(&t(&[x, -x], &[x as f32 / 100.0], &[x + 1.0, -x - 1.0], i % 3 == 0)).unwrap();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut batch = Batch::new(64, 2, 1);
        buf.sample_into(&mut rng, &mut batch).unwrap();
        for r in 0..64 {
            let x = batch.obs[2 * r];
            assert_eq!(batch.obs[2 * r + 1], -x);
            assert_eq!(batch.next_obs[2 * r], x + 1.0);
            assert_eq!(batch.rewards[r], x);
            assert_eq!(batch.actions[r], x / 100.0);
            let term = (x as usize).is_multiple_of(3);
            assert_eq!(batch.terminated[r], if term { 1.0 } else { 0.0 });
        }
    }

    #[test]
    fn save_load_round_trip_and_shape_check() {
        let dir = tempfile::tempdir().unwrap();
        let mut buf = ReplayBuffer::new(4, 2, 1).unwrap();
        for i in 0..6 {
            let x = f64::from(i);
            buf.push(&t(&[x, 2.0 * x], &[0.25 * x as f32], &[x, 1.0], i == 4)).unwrap();
        }
        let path = dir.path().join("replay.bin");
        buf.save(&path).unwrap();
        let mut back = ReplayBuffer::new(4, 2, 1).unwrap();
        back.load(&path).unwrap();
        assert_eq!((back.pos, back.full), (buf.pos, buf.full));
        assert_eq!(back.obs, buf.obs);
        assert_eq!(back.next_obs, buf.next_obs);
        assert_eq!(back.actions, buf.actions);
        assert_eq!(back.rewards, buf.rewards);
        assert_eq!(back.costs, buf.costs);
        assert!(back.costs.contains(&1.0));
        assert_eq!(back.terminated, buf.terminated);
        assert_eq!(back.truncated, buf.truncated);
        // Demonstrations keep their flag through a save.
        buf.push_demonstration(&t(&[9.0, 9.0], &[0.5], &[9.0, 9.0], false), true).unwrap();
        buf.save(&path).unwrap();
        back.load(&path).unwrap();
        assert_eq!((back.bc_count(), &back.bc), (1, &buf.bc));
        let mut other = ReplayBuffer::new(5, 2, 1).unwrap();
        assert!(matches!(other.load(&path), Err(RlError::Checkpoint { .. })));
    }

    #[test]
    fn rejects_bad_transitions_and_empty_sampling() {
        let mut buf = ReplayBuffer::new(4, 2, 1).unwrap();
        assert!(buf.push(&t(&[0.0], &[0.0], &[0.0, 0.0], false)).is_err());
        assert!(buf.push(&t(&[0.0, f64::NAN], &[0.0], &[0.0, 0.0], false)).is_err());
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        assert!(buf.sample_into(&mut rng, &mut Batch::new(2, 2, 1)).is_err());
    }
}
