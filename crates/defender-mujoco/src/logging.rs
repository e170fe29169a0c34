//! MuJoCo's own messages, routed to `tracing`.
//!
//! By default MuJoCo prints warnings to stdout and appends them to `MUJOCO_LOG.TXT` in the
//! working directory. A training run must not write files where it was started, and its logs go
//! through `tracing`, so the first environment built installs a MuJoCo log handler that forwards
//! every message to `tracing` (target `mujoco`).

use std::sync::Once;

use mujoco_rs::prelude::{MjLogMessage, MjtLogLevel, set_log_handler};

static ROUTE: Once = Once::new();

fn forward(message: &MjLogMessage) {
    // mujoco-rs panics on text that is not UTF-8; a panic must not cross the FFI boundary.
    let _ = std::panic::catch_unwind(|| {
        let subject = message.subject();
        let body = message.body().unwrap_or("");
        match message.level() {
            MjtLogLevel::mjLOG_ERROR => tracing::error!(target: "mujoco", "{subject} {body}"),
            MjtLogLevel::mjLOG_WARNING => tracing::warn!(target: "mujoco", "{subject} {body}"),
            MjtLogLevel::mjLOG_INFO => tracing::info!(target: "mujoco", "{subject} {body}"),
            _ => tracing::debug!(target: "mujoco", "{subject} {body}"),
        }
    });
}

/// Installs the handler once per process. Every MuJoCo call of this crate happens after it (each
/// environment constructor calls this first), so no thread of ours is inside MuJoCo meanwhile.
pub(crate) fn route_mujoco_log_to_tracing() {
    ROUTE.call_once(|| {
        // SAFETY: `Once` serialises the call, and this crate touches MuJoCo only after it; the
        // handler is thread-safe (it only formats and calls `tracing`) and never panics.
        unsafe { set_log_handler(forward) };
    });
}
