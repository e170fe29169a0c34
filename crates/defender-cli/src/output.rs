//! Printing that never panics. `println!` and `eprintln!` panic when their stream cannot be
//! written (`>/dev/full`, a closed descriptor): a finished run would then exit 101 before its
//! last words, and a warning on a full stderr would stop a run before it starts. Here a failed
//! write to stdout is remembered and makes the command exit 1 once its work is done and its
//! files are written (`main`); a failed write to stderr is dropped, as there is nowhere left to
//! say it. A closed pipe (`| head`) still ends the process by SIGPIPE, as for any Unix tool.

use std::io::{self, Write};
use std::sync::OnceLock;

/// The first error of writing to stdout, if any.
static STDOUT_ERROR: OnceLock<String> = OnceLock::new();

/// Writes to stdout and flushes; an error is kept for [`stdout_error`].
pub fn out(args: std::fmt::Arguments<'_>) {
    let mut stdout = io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        let _ = STDOUT_ERROR.set(e.to_string());
    }
}

/// Writes to stderr; an error is ignored.
pub fn err(args: std::fmt::Arguments<'_>) {
    let mut stderr = io::stderr().lock();
    let _ = stderr.write_fmt(args).and_then(|()| stderr.flush());
}

/// Why stdout could not be written, if it could not.
pub fn stdout_error() -> Option<&'static str> {
    STDOUT_ERROR.get().map(String::as_str)
}

/// `println!` that never panics ([`out`]).
macro_rules! say {
    () => {
        $crate::output::out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::output::out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that never panics ([`out`]).
macro_rules! put {
    ($($arg:tt)*) => {
        $crate::output::out(format_args!($($arg)*))
    };
}

/// `eprintln!` that never panics ([`err`]).
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::output::err(format_args!("{}\n", format_args!($($arg)*)))
    };
}
