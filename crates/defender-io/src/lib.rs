//! Durable output for every writer in defender: one home for the rules that keep a run's files
//! whole when the process is interrupted at any moment (Ctrl-C, SIGTERM, kill -9, power loss).
//!
//! - [`write_file`] writes a file atomically: a temporary file in the same directory, synced,
//!   renamed over the target, and the directory synced, so a reader sees the old file or the new
//!   one, never a torn one, and no temporary file is left behind on error.
//! - [`replace_dir`] does the same for a whole directory (a checkpoint), and [`resolve_dir`] finds
//!   the complete one after an interruption between its two renames.
//! - [`open_input`] opens a user's input only if it is a regular file (a device, a FIFO or a
//!   directory is refused at once, naming it), so that no read hangs or never ends.
//! - [`DirLock`] is an exclusive, advisory lock on a directory held for a process's lifetime
//!   (released by the kernel when the process dies, so a kill -9 never leaves a stale lock).

mod atomic;
mod input;
mod lock;

pub use atomic::{replace_dir, resolve_dir, sync_dir, tmp_sibling, write_bytes, write_file};
pub use input::{check_regular, open_input, read_input, read_input_to_string};
pub use lock::{DirLock, LockError};
