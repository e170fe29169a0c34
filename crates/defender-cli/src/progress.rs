//! Progress on long work. On a terminal (stderr) a bar redrawn in place, as Stable-Baselines3's
//! progress bar and tqdm draw it. Elsewhere (a log file, `nohup`, a sweep's per-run log, a Ray
//! worker) one plain line every `DEFENDER_PROGRESS_INTERVAL` seconds (default 60; `off` for
//! none), so `tail -f` on a log shows a run is alive and how far it is, without a carriage-return
//! bar filling the file.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle, TermLike};

/// The environment variable that sets the seconds between two progress lines off a terminal.
pub const INTERVAL_VAR: &str = "DEFENDER_PROGRESS_INTERVAL";
const DEFAULT_INTERVAL: Duration = Duration::from_secs(60);

/// A progress bar over `total` units of `unit` (e.g. "steps", "episodes"): drawn on a terminal,
/// a line every interval otherwise (see the module's documentation).
pub fn bar(total: u64, unit: &str) -> ProgressBar {
    let on_terminal = std::io::stderr().is_terminal();
    let (target, template) = if on_terminal {
        (
            ProgressDrawTarget::stderr_with_hz(4),
            format!(
                "{{elapsed_precise}} [{{bar:30}}] {{pos}}/{{len}} {unit} ({{rate}}, eta {{eta}}) {{msg}}"
            ),
        )
    } else {
        let target = match interval() {
            Some(every) => ProgressDrawTarget::term_like_with_hz(Box::new(Lines::new(every)), 1),
            None => ProgressDrawTarget::hidden(),
        };
        (
            target,
            format!("progress: {{elapsed_precise}} {{pos}}/{{len}} {unit} ({{rate}}, eta {{eta}}) {{msg}}"),
        )
    };
    let bar = ProgressBar::with_draw_target(Some(total), target);
    if let Ok(style) = ProgressStyle::with_template(&template) {
        // indicatif's own `{per_sec}` prints four decimals of a rate of thousands; a slow unit
        // (episodes of an ablation) keeps one decimal, so 0.6/s does not read as 1/s.
        let rate = |state: &ProgressState, w: &mut dyn std::fmt::Write| {
            let per_sec = state.per_sec();
            let _ = if per_sec < 10.0 { write!(w, "{per_sec:.1}/s") } else { write!(w, "{per_sec:.0}/s") };
        };
        bar.set_style(style.progress_chars("=> ").with_key("rate", rate));
    }
    bar
}

/// The interval between two lines off a terminal: `DEFENDER_PROGRESS_INTERVAL` in seconds, `off`
/// (or `none`) for no lines; unset or unreadable values give the default, with a warning for the
/// latter so a typo does not pass unnoticed.
fn interval() -> Option<Duration> {
    let Ok(text) = std::env::var(INTERVAL_VAR) else { return Some(DEFAULT_INTERVAL) };
    parse_interval(&text).unwrap_or_else(|| {
        note!(
            "warning: {INTERVAL_VAR}={text:?} is neither seconds (e.g. 30) nor `off`; using {}s",
            DEFAULT_INTERVAL.as_secs()
        );
        Some(DEFAULT_INTERVAL)
    })
}

/// `Some(None)` = off, `Some(Some(d))` = every `d`, `None` = not understood.
fn parse_interval(text: &str) -> Option<Option<Duration>> {
    let text = text.trim();
    if text.eq_ignore_ascii_case("off") || text.eq_ignore_ascii_case("none") {
        return Some(None);
    }
    let seconds: f64 = text.parse().ok()?;
    (seconds.is_finite() && seconds >= 0.0).then(|| Some(Duration::from_secs_f64(seconds)))
}

/// A "terminal" that keeps what indicatif draws and writes it to stderr as one line, at most once
/// per interval; cursor movements and clearing mean nothing in a file, so they are dropped.
#[derive(Debug)]
struct Lines {
    every: Duration,
    state: Mutex<LinesState>,
}

#[derive(Debug)]
struct LinesState {
    pending: String,
    last: Instant,
}

impl Lines {
    fn new(every: Duration) -> Self {
        Self { every, state: Mutex::new(LinesState { pending: String::new(), last: Instant::now() }) }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, LinesState> {
        // A panic elsewhere while the lock was held leaves only a half-drawn line behind.
        self.state.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl TermLike for Lines {
    fn width(&self) -> u16 {
        // Wide enough that indicatif never cuts a sweep's list of running runs.
        1000
    }

    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }

    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }

    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }

    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }

    fn write_line(&self, s: &str) -> std::io::Result<()> {
        let mut state = self.state();
        state.pending.push_str(s);
        state.pending.push(' ');
        Ok(())
    }

    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.state().pending.push_str(s);
        Ok(())
    }

    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }

    fn flush(&self) -> std::io::Result<()> {
        let mut state = self.state();
        let line = std::mem::take(&mut state.pending).replace('\r', "");
        let line = line.trim();
        if line.is_empty() || state.last.elapsed() < self.every {
            return Ok(());
        }
        state.last = Instant::now();
        let mut err = std::io::stderr().lock();
        writeln!(err, "{line}")?;
        err.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interval_reads_seconds_and_off_and_refuses_the_rest() {
        assert_eq!(parse_interval("30"), Some(Some(Duration::from_secs(30))));
        assert_eq!(parse_interval(" 0.5 "), Some(Some(Duration::from_millis(500))));
        assert_eq!(parse_interval("0"), Some(Some(Duration::ZERO)));
        assert_eq!(parse_interval("off"), Some(None));
        assert_eq!(parse_interval("None"), Some(None));
        assert_eq!(parse_interval("-1"), None);
        assert_eq!(parse_interval("inf"), None);
        assert_eq!(parse_interval("1m"), None);
    }
}
