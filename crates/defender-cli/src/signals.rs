//! Stopping cleanly on a signal. SIGINT (Ctrl-C), SIGTERM (what Slurm, Ray, Kubernetes and
//! `timeout` send) and SIGHUP (a closed terminal) all ask a run to stop at its next safe point:
//! the end of the current episode, where a checkpoint and the summary are written. A second
//! signal ends the process at once, with the conventional exit code.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use anyhow::{Context, Result};
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};

/// The signals that ask for a clean stop.
pub const STOP_SIGNALS: [i32; 3] = [SIGINT, SIGTERM, SIGHUP];

/// Which stop signal arrived (0: none yet). Shared with the signal handlers.
#[derive(Debug, Clone)]
pub struct StopRequest {
    signal: Arc<AtomicUsize>,
    requested: Arc<AtomicBool>,
}

impl StopRequest {
    /// Installs the handlers for SIGINT, SIGTERM and SIGHUP: the first one of them sets the
    /// request, a second one exits at once with `128 + signal`.
    pub fn install() -> Result<Self> {
        let request =
            Self { signal: Arc::new(AtomicUsize::new(0)), requested: Arc::new(AtomicBool::new(false)) };
        for sig in STOP_SIGNALS {
            // Order matters: the conditional shutdown sees the flag set by an earlier signal.
            signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&request.requested))
                .with_context(|| format!("cannot install the handler of signal {sig}"))?;
            signal_hook::flag::register(sig, Arc::clone(&request.requested))
                .with_context(|| format!("cannot install the handler of signal {sig}"))?;
            signal_hook::flag::register_usize(sig, Arc::clone(&request.signal), sig as usize)
                .with_context(|| format!("cannot install the handler of signal {sig}"))?;
        }
        Ok(request)
    }

    /// Whether a stop was asked for.
    pub fn is_requested(&self) -> bool {
        self.requested.load(Ordering::SeqCst)
    }

    /// The signal that asked for the stop, if one did.
    pub fn signal(&self) -> Option<i32> {
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            s => i32::try_from(s).ok(),
        }
    }

    /// The conventional exit code of a process stopped by the signal: 128 + its number (130
    /// after SIGINT, 143 after SIGTERM, 129 after SIGHUP).
    pub fn exit_code(&self) -> Option<u8> {
        self.signal().and_then(|s| u8::try_from(128 + s).ok())
    }
}

/// An error that carries the exit code of a run stopped by a signal, so `main` exits with it.
#[derive(Debug)]
pub struct Stopped {
    /// The process exit code.
    pub code: u8,
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "stopped by a signal (exit code {})", self.code)
    }
}

impl std::error::Error for Stopped {}
