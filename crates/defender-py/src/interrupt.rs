//! Long Rust work that answers Ctrl-C (a strategy selection, an ablation: seconds to minutes).
//!
//! Python runs signal handlers only on the main thread, with the GIL, between bytecodes: a Rust
//! call that works for a minute without the GIL would swallow Ctrl-C until it returns. So the
//! work runs on a thread of its own while the calling thread wakes every 100 ms to run the
//! handlers (`Python::check_signals`). When one raises (`KeyboardInterrupt`), the exception is
//! raised at once and the work is told to stop: each of its worker threads unwinds (with
//! `resume_unwind`: no panic message) at its next finished episode, and the result is dropped.
//! (rayon still starts the parallel pieces not yet begun, each for one episode, so the threads
//! wind down over about a second per piece in the background; the caller does not wait.)

use std::panic::resume_unwind;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use defender::Progress;
use pyo3::prelude::*;

/// How often the waiting thread runs Python's signal handlers.
const POLL: Duration = Duration::from_millis(100);

/// The payload of the unwind that stops cancelled work.
struct Cancelled;

/// Runs `work(progress)` without the GIL on a thread of its own, answering Ctrl-C within
/// `POLL`. `work` must pass `progress` to the library's long loops (it stops them once
/// cancelled).
///
/// # Errors
/// The signal handler's exception (`KeyboardInterrupt`). A panic inside `work` is resumed (the
/// caller's `guard` turns it into a `RuntimeError`).
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(&(dyn Fn(Progress) + Sync)) -> T + Send + 'static,
) -> PyResult<T> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&cancel);
    let handle = std::thread::Builder::new()
        .name("defender-work".into())
        .spawn(move || {
            let progress = |_: Progress| {
                if flag.load(Ordering::Relaxed) {
                    resume_unwind(Box::new(Cancelled));
                }
            };
            work(&progress)
        })
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("cannot start a thread: {e}")))?;
    loop {
        let finished = py.detach(|| {
            let until = Instant::now() + POLL;
            while !handle.is_finished() && Instant::now() < until {
                std::thread::sleep(Duration::from_millis(5));
            }
            handle.is_finished()
        });
        if finished {
            return match handle.join() {
                Ok(v) => Ok(v),
                Err(payload) => resume_unwind(payload),
            };
        }
        if let Err(e) = py.check_signals() {
            // Not joined: the thread ends by itself (see the module's documentation).
            cancel.store(true, Ordering::Relaxed);
            return Err(e);
        }
    }
}
