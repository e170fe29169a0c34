//! Run directories (docs/run-directory.md), as `defender report` reads them.
//!
//! One input is a whole directory: sections that each start with a line `==> NAME <==` (as
//! `head` prints several files), NAME one of the run's files; the text up to the next such line
//! is that file. Sections for other names are ignored (no input writes outside the directory),
//! and a file without a section is absent.

use defender_report::{CONFIG_FILE, EVAL_FILE, METRICS_FILE, SUMMARY_FILE};

use crate::scratch;

/// The files of a run directory that `Run::load` reads.
const FILES: [&str; 4] = [CONFIG_FILE, SUMMARY_FILE, METRICS_FILE, EVAL_FILE];

/// The files of `data`, as `(name, content)`.
pub fn sections(data: &[u8]) -> Vec<(&'static str, &[u8])> {
    let mut out: Vec<(&'static str, &[u8])> = Vec::new();
    let mut current: Option<(&'static str, usize)> = None;
    let mut at = 0;
    for line in data.split_inclusive(|&b| b == b'\n') {
        let trimmed = line.strip_suffix(b"\n").unwrap_or(line);
        if let Some(name) = trimmed.strip_prefix(b"==> ").and_then(|r| r.strip_suffix(b" <==")) {
            if let Some((file, start)) = current.take() {
                out.push((file, &data[start..at]));
            }
            current = FILES.iter().find(|f| f.as_bytes() == name).map(|&f| (f, at + line.len()));
        }
        at += line.len();
    }
    if let Some((file, start)) = current {
        out.push((file, &data[start..]));
    }
    out
}

/// A run directory made of `data`'s sections, read as `defender report` reads it.
pub fn run_directory(data: &[u8]) -> bool {
    let dir = scratch::thread_path("run");
    let _ = std::fs::remove_dir_all(&dir);
    if std::fs::create_dir_all(&dir).is_err() {
        return false;
    }
    for (name, content) in sections(data) {
        if std::fs::write(dir.join(name), content).is_err() {
            return false;
        }
    }
    let ok = defender_report::Run::load(&dir).is_ok();
    // And as a set of runs (discovery, then each run; what `report` does with its arguments).
    let _ = defender_report::load_runs(&[&dir]);
    ok
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_split_at_their_headers_and_ignore_other_names() {
        let data = b"junk\n==> config.toml <==\na = 1\n==> ../escape <==\nx\n==> eval.csv <==\nh\n";
        let s = sections(data);
        assert_eq!(s, [(CONFIG_FILE, &b"a = 1\n"[..]), (EVAL_FILE, &b"h\n"[..])]);
        assert!(!run_directory(data));
    }
}
