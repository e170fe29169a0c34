//! One call at a time into a `DefenderWrapper`, without deadlocks (docs/decisions.md, "Misuse
//! never hangs").
//!
//! A call into the wrapper may run Python (the wrapped environment's `step`), and that Python may
//! let the GIL go (`time.sleep`, I/O, a simulator's C code). So a second thread can enter the
//! wrapper while the first is inside: it waits for its turn **without the GIL** (the first needs
//! the GIL back to return), waking every 50 ms to answer Ctrl-C. A call from the thread that is
//! already inside (the wrapped environment, or a callback it runs, calling the wrapper again)
//! can never get its turn: it raises at once, naming both methods.

use std::sync::{Condvar, Mutex, PoisonError};
use std::thread::ThreadId;
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often a waiting thread checks for Ctrl-C (Python's signal handlers run only on the main
/// thread with the GIL: `check_signals` raises `KeyboardInterrupt` there).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Who is inside.
struct Holder {
    thread: ThreadId,
    method: &'static str,
}

/// The turnstile of one wrapper.
#[derive(Default)]
pub(crate) struct Turns {
    holder: Mutex<Option<Holder>>,
    free: Condvar,
}

/// A call's turn; dropping it lets the next waiting thread in.
pub(crate) struct Turn<'a> {
    turns: &'a Turns,
}

impl Turns {
    /// Waits for the turn of `method` (the Python name, e.g. `"step"`), the GIL released while
    /// waiting.
    ///
    /// # Errors
    /// `RuntimeError` at once for a re-entrant call from the thread inside; `KeyboardInterrupt`
    /// (or a signal handler's exception) while waiting.
    pub(crate) fn take(&self, py: Python<'_>, method: &'static str) -> PyResult<Turn<'_>> {
        let me = std::thread::current().id();
        loop {
            {
                let mut holder = self.holder.lock().unwrap_or_else(PoisonError::into_inner);
                match &*holder {
                    None => {
                        *holder = Some(Holder { thread: me, method });
                        return Ok(Turn { turns: self });
                    }
                    Some(h) if h.thread == me => {
                        return Err(PyRuntimeError::new_err(format!(
                            "DefenderWrapper.{method}() was called while DefenderWrapper.{}() is still \
                             running on this thread (from inside the wrapped environment or a callback it \
                             runs): the wrapper is not re-entrant; call {method}() after {}() has returned",
                            h.method, h.method
                        )));
                    }
                    Some(_) => {}
                }
            }
            py.detach(|| {
                let holder = self.holder.lock().unwrap_or_else(PoisonError::into_inner);
                // Woken by the holder's drop, or by the timeout to look at signals.
                drop(self.free.wait_timeout_while(holder, SIGNAL_POLL, |h| h.is_some()));
            });
            py.check_signals()?;
        }
    }
}

impl Drop for Turn<'_> {
    fn drop(&mut self) {
        *self.turns.holder.lock().unwrap_or_else(PoisonError::into_inner) = None;
        self.turns.free.notify_one();
    }
}
