//! The README's commands are a test, and so are those of the two pages its long parts moved to
//! (docs/cli.md, the command line; docs/python.md, the Python package): every `defender` command
//! in their shell code blocks that runs in seconds on the committed files is run (and must
//! succeed); every other one must at least parse (`--list` for a sweep, else the command with `--help` appended, which clap only
//! reaches after checking every flag and value before it). `make` targets must exist in the
//! Makefile. A command of a kind this test does not know fails it, so none goes unchecked.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The pages whose `sh` code blocks this test checks.
const PAGES: [&str; 3] = ["README.md", "docs/cli.md", "docs/python.md"];

/// The commands that run in seconds on the committed files, as the pages write them.
const RUN: [&str; 3] = [
    "defender env list",
    "defender report results/table1 --plots results/table1/plots",
    "defender report results/keeps-learning --plots plots/ --strict",
];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

/// The commands of a page's `sh` code blocks: continuation lines joined, comments dropped.
fn sh_commands(page: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join(page)).unwrap_or_else(|e| panic!("{page}: {e}"));
    let mut commands = Vec::new();
    let mut in_sh = false;
    let mut pending = String::new();
    for line in text.lines() {
        if let Some(lang) = line.strip_prefix("```") {
            in_sh = !in_sh && lang.trim() == "sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        let code = line.split(" #").next().unwrap().trim();
        if code.starts_with('#') || (code.is_empty() && pending.is_empty()) {
            continue;
        }
        match code.strip_suffix('\\') {
            Some(head) => pending.push_str(head),
            None => {
                pending.push_str(code);
                commands.push(pending.split_whitespace().collect::<Vec<_>>().join(" "));
                pending.clear();
            }
        }
    }
    commands
}

/// The words of a command, an optional part `[--flag a|b]` taken with its first choice.
fn words(command: &str) -> Vec<String> {
    command
        .split_whitespace()
        .map(|w| w.trim_start_matches('[').trim_end_matches(']'))
        .map(|w| w.split('|').next().unwrap().to_string())
        .collect()
}

/// A scratch copy of what the commands read, so that what they write stays out of the tree.
fn workspace() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for link in ["data", "experiments"] {
        std::os::unix::fs::symlink(root().join(link), dir.path().join(link)).unwrap();
    }
    let copy = Command::new("cp").arg("-r").arg(root().join("results")).arg(dir.path()).status().unwrap();
    assert!(copy.success());
    dir
}

fn defender(cwd: &Path, args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_defender"))
        .args(args)
        .current_dir(cwd)
        .env("DEFENDER_PROGRESS_INTERVAL", "off")
        .output()
        .unwrap()
}

#[test]
fn every_readme_command_runs_or_at_least_parses() {
    let mut commands = Vec::new();
    for page in PAGES {
        let found = sh_commands(page);
        assert!(!found.is_empty(), "{page}: no command in its `sh` code blocks");
        commands.extend(found.into_iter().map(|c| (page, c)));
    }
    assert!(commands.len() > 20, "found only {} commands: {commands:?}", commands.len());
    for run in RUN {
        assert!(commands.iter().any(|(_, c)| c == run), "`{run}` is in none of {PAGES:?}: update RUN");
    }
    let makefile = std::fs::read_to_string(root().join("Makefile")).unwrap();
    let scratch = workspace();
    let cwd = scratch.path();
    for (page, command) in &commands {
        let w = words(command);
        match w[0].as_str() {
            "defender" => {
                let mut args = w[1..].to_vec();
                if !RUN.contains(&command.as_str()) {
                    args.push(if args[0] == "sweep" { "--list" } else { "--help" }.to_string());
                }
                let out = defender(cwd, &args);
                let text = format!(
                    "{}{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
                assert!(out.status.success(), "{page}: `{command}` (run as {args:?}) failed:\n{text}");
            }
            "make" => {
                for target in w[1..].iter().filter(|t| !t.contains('=')) {
                    assert!(
                        makefile.contains(&format!("\n{target}:")),
                        "{page}: `{command}`: no target {target}"
                    );
                }
            }
            // Installing is what `make test-wheel` checks, in a fresh venv.
            "pip" => assert!(command.starts_with("pip install "), "{page}: `{command}`"),
            other => panic!("{page}: `{command}`: a command of a kind this test does not check ({other})"),
        }
    }
}
