//! Where [`DefenderEnv`](crate::DefenderEnv) trains its dynamics model: inline, in the step that
//! produced the transition (SPEC section 5's default), or on a thread of its own.
//!
//! The model's gradient step (a batch of 256 through obs+act -> 256 -> 256 -> obs) costs about
//! 1.1 ms on this project's machine against about 7 ms for a SAC update, and it is most of
//! DEFENDER's overhead (docs/benchmarks.md). Nothing needs the model until a step is filtered, so
//! with `background` the transition is handed to a worker thread that trains while the agent
//! updates, on another core. The worker takes transitions in order, one at a time, with the
//! model's own RNG, and every reader (a prediction, a checkpoint, the counters) first waits until
//! the queue is empty: the model is bit for bit the one inline training gives, whatever the timing.
//! The queue holds one transition, so a worker that falls behind (before the agent's
//! `learning_starts`, when steps are fast) slows the steps down instead of piling work up.

use std::fmt;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use defender_nn::Parallelism;

use crate::dynamics::DynamicsModel;
use crate::error::{DefenderError, Result};

/// The dynamics model, trained inline or by a worker thread.
pub(crate) struct TrainedDynamics {
    model: Arc<Mutex<DynamicsModel>>,
    obs_dim: usize,
    act_dim: usize,
    worker: Option<Worker>,
}

struct Worker {
    queue: Option<SyncSender<Vec<f64>>>,
    // Emptied transition buffers come back here, so that a step allocates nothing once warm.
    recycled: Receiver<Vec<f64>>,
    progress: Arc<(Mutex<Progress>, Condvar)>,
    handle: Option<JoinHandle<()>>,
}

#[derive(Default)]
struct Progress {
    sent: u64,
    done: u64,
    // The model refused a transition the pre-checks let through (never expected).
    failure: Option<String>,
    // The thread has ended (it panicked, or the queue closed).
    stopped: bool,
}

/// A read-only view of the dynamics model that can be kept apart from its environment (e.g. by
/// a logger), cheap to clone; it reads the model once every transition handed over so far has
/// been learnt from, as [`TrainedDynamics::model`] does.
#[derive(Clone)]
pub struct DynamicsHandle {
    model: Arc<Mutex<DynamicsModel>>,
    progress: Option<Arc<(Mutex<Progress>, Condvar)>>,
}

impl DynamicsHandle {
    /// Calls `read` on the model once it has caught up.
    ///
    /// # Errors
    /// With `background`: the model's thread stopped (it panicked) or failed.
    pub fn read<T>(&self, read: impl FnOnce(&DynamicsModel) -> T) -> Result<T> {
        if let Some(progress) = &self.progress {
            wait_until_idle(progress, || false)?;
        }
        Ok(read(&lock(&self.model)))
    }
}

impl fmt::Debug for DynamicsHandle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DynamicsHandle").field("background", &self.progress.is_some()).finish_non_exhaustive()
    }
}

/// Waits until the worker has learnt from every transition sent, or has stopped or failed.
fn wait_until_idle(progress: &(Mutex<Progress>, Condvar), finished: impl Fn() -> bool) -> Result<()> {
    let (state, idle) = progress;
    let mut p = lock(state);
    while p.done < p.sent {
        // A thread that panicked never reports its transition done: look, now and then.
        if p.stopped || finished() {
            return Err(DefenderError::Worker("it has stopped (see the panic message above)".into()));
        }
        p = idle.wait_timeout(p, Duration::from_millis(100)).unwrap_or_else(PoisonError::into_inner).0;
    }
    match &p.failure {
        Some(reason) => Err(DefenderError::Worker(reason.clone())),
        None => Ok(()),
    }
}

impl TrainedDynamics {
    /// Wraps `model`; with `background`, starts its worker thread and makes the model's GEMMs
    /// sequential (the thread is the model's one core; results do not depend on it).
    pub(crate) fn new(mut model: DynamicsModel, background: bool) -> Result<Self> {
        if background {
            model.set_parallelism(Parallelism::Sequential);
        }
        let (obs_dim, act_dim) = (model.obs_dim(), model.act_dim());
        let model = Arc::new(Mutex::new(model));
        let worker = if background { Some(Worker::start(Arc::clone(&model))?) } else { None };
        Ok(Self { model, obs_dim, act_dim, worker })
    }

    /// Whether a worker thread trains the model.
    pub(crate) fn is_background(&self) -> bool {
        self.worker.is_some()
    }

    /// One real transition (as [`DynamicsModel::observe`]). In the background the transition is
    /// checked here, so that bad input is still refused by the step that brought it.
    pub(crate) fn observe(&mut self, obs: &[f64], action: &[f64], next_obs: &[f64]) -> Result<()> {
        let Some(worker) = &mut self.worker else {
            return lock(&self.model).observe(obs, action, next_obs);
        };
        DynamicsModel::check_transition(self.obs_dim, self.act_dim, obs, action, next_obs)?;
        worker.send(obs, action, next_obs)
    }

    /// Replaces the model (a checkpoint's), sequential in the background as in [`Self::new`].
    pub(crate) fn replace(&mut self, mut model: DynamicsModel) -> Result<()> {
        if self.is_background() {
            model.set_parallelism(Parallelism::Sequential);
        }
        *self.model()? = model;
        Ok(())
    }

    /// A handle that reads the model apart from the environment.
    pub(crate) fn handle(&self) -> DynamicsHandle {
        DynamicsHandle {
            model: Arc::clone(&self.model),
            progress: self.worker.as_ref().map(|w| Arc::clone(&w.progress)),
        }
    }

    /// The model, once every transition handed over so far has been learnt from.
    pub(crate) fn model(&self) -> Result<MutexGuard<'_, DynamicsModel>> {
        if let Some(worker) = &self.worker {
            worker.wait_idle()?;
        }
        Ok(lock(&self.model))
    }
}

impl Worker {
    fn start(model: Arc<Mutex<DynamicsModel>>) -> Result<Self> {
        let (queue, inbox) = sync_channel::<Vec<f64>>(1);
        let (give_back, recycled) = sync_channel::<Vec<f64>>(4);
        let progress = Arc::new((Mutex::new(Progress::default()), Condvar::new()));
        let shared = Arc::clone(&progress);
        let handle = std::thread::Builder::new()
            .name("defender-dynamics".into())
            .spawn(move || {
                // Marks the thread stopped however it ends, so that waiting readers return.
                let _stopped = StopMark(Arc::clone(&shared));
                let (obs_dim, act_dim) = {
                    let m = lock(&model);
                    (m.obs_dim(), m.act_dim())
                };
                for transition in inbox {
                    let (obs, rest) = transition.split_at(obs_dim);
                    let (action, next_obs) = rest.split_at(act_dim);
                    let result = lock(&model).observe(obs, action, next_obs);
                    let (state, idle) = &*shared;
                    let mut p = lock(state);
                    p.done += 1;
                    if let Err(e) = result {
                        p.failure.get_or_insert_with(|| e.to_string());
                    }
                    idle.notify_all();
                    drop(p);
                    // Full or gone: then the buffer is simply freed.
                    let _ = give_back.try_send(transition);
                }
            })
            .map_err(|e| DefenderError::Worker(format!("cannot start: {e}")))?;
        Ok(Self { queue: Some(queue), recycled, progress, handle: Some(handle) })
    }

    fn send(&mut self, obs: &[f64], action: &[f64], next_obs: &[f64]) -> Result<()> {
        let mut buf = self.recycled.try_recv().unwrap_or_default();
        buf.clear();
        buf.extend_from_slice(obs);
        buf.extend_from_slice(action);
        buf.extend_from_slice(next_obs);
        lock(&self.progress.0).sent += 1;
        let sent = self.queue.as_ref().map(|q| q.send(buf));
        if !matches!(sent, Some(Ok(()))) {
            return Err(DefenderError::Worker("it has stopped (see the panic message above)".into()));
        }
        Ok(())
    }

    fn wait_idle(&self) -> Result<()> {
        wait_until_idle(&self.progress, || self.handle.as_ref().is_none_or(JoinHandle::is_finished))
    }
}

/// Sets `stopped` when dropped: at the end of the worker's thread, also when it unwinds.
struct StopMark(Arc<(Mutex<Progress>, Condvar)>);

impl Drop for StopMark {
    fn drop(&mut self) {
        let (state, idle) = &*self.0;
        lock(state).stopped = true;
        idle.notify_all();
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the queue ends the worker's loop once it has finished what it holds.
        self.queue = None;
        if let Some(handle) = self.handle.take() {
            let _ = handle.join();
        }
    }
}

/// Locks, recovering the data if a panicking thread poisoned the lock: the model's state is
/// valid between calls, and a panic is reported by the thread's end (see `wait_idle`).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl fmt::Debug for TrainedDynamics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TrainedDynamics")
            .field("obs_dim", &self.obs_dim)
            .field("act_dim", &self.act_dim)
            .field("background", &self.is_background())
            .finish_non_exhaustive()
    }
}
