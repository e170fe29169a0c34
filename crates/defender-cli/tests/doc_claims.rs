//! What the documentation says about the repository holds: every section it cites by heading
//! exists, every document it cites exists, the experiment files with committed runs name the
//! profile they were made with, as docs/cli.md says, and what users read names no internal
//! tracker issue by number.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The documents a reader meets: the README, docs/*.md and the scripts.
fn documents() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md")];
    for dir in ["docs", "scripts"] {
        for entry in std::fs::read_dir(root().join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.is_file() {
                files.push(path);
            }
        }
    }
    files
}

/// `(file, heading)` for each citation `docs/X.md, "Heading"` or `(docs/X.md), "Heading"` (or
/// `X.md` from inside docs/), whitespace collapsed.
fn citations(text: &str) -> Vec<(String, String)> {
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut found = Vec::new();
    let mut rest = flat.as_str();
    while let Some(at) = rest.find(".md") {
        let before = &rest[..at];
        let name_start =
            before.rfind(|c: char| !(c.is_alphanumeric() || "-_/.".contains(c))).map_or(0, |i| i + 1);
        let file = format!("{}.md", &before[name_start..]);
        let after = rest[at + 3..].trim_start_matches(')');
        if let Some(quoted) = after.strip_prefix(", \"")
            && let Some(end) = quoted.find('"')
            && file.chars().next().is_some_and(char::is_alphanumeric)
        {
            found.push((file, quoted[..end].to_string()));
        }
        rest = &rest[at + 3..];
    }
    found
}

/// A document's section names: its headings, and the bold lead-ins of its paragraphs and list
/// items (`- **Threads.**`).
fn headings(path: &Path) -> Vec<String> {
    let text = read(path);
    let titles =
        text.lines().filter(|l| l.starts_with('#')).map(|l| l.trim_start_matches('#').trim().to_string());
    let leads = text
        .lines()
        .filter_map(|l| l.trim_start().trim_start_matches("- ").strip_prefix("**")?.split("**").next())
        .map(|l| l.trim_end_matches('.').to_string());
    titles.chain(leads).collect()
}

#[test]
fn every_section_cited_by_its_heading_exists() {
    let (mut checked, mut broken) = (0, Vec::new());
    for doc in documents() {
        for (file, heading) in citations(&read(&doc)) {
            let name = Path::new(&file).file_name().unwrap();
            let target =
                [root().join(&file), root().join("docs").join(name)].into_iter().find(|p| p.is_file());
            let Some(target) = target else { continue };
            if !headings(&target).iter().any(|h| h.contains(&heading)) {
                broken.push(format!("{} cites {file}, \"{heading}\": no such heading", doc.display()));
            }
            checked += 1;
        }
    }
    assert!(broken.is_empty(), "{}", broken.join("\n"));
    assert!(checked > 10, "only {checked} citations found");
}

#[test]
fn no_document_cites_a_file_the_repository_does_not_have() {
    for doc in documents() {
        let text = read(&doc);
        assert!(
            !text.contains("DESIGN"),
            "{} cites DESIGN.md, which the repository does not have",
            doc.display()
        );
    }
    assert!(root().join("docs/architecture.md").is_file());
}

#[test]
fn experiment_files_with_committed_runs_name_their_profile() {
    for entry in std::fs::read_dir(root().join("experiments")).unwrap() {
        let path = entry.unwrap().path();
        let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
        if path.extension().is_some_and(|e| e == "toml") && root().join("results").join(&stem).is_dir() {
            let text = read(&path);
            assert!(
                text.lines().any(|l| l.trim_start().starts_with("profile")),
                "{}: its runs are committed under results/{stem} but it names no profile",
                path.display()
            );
        }
    }
}

/// Every file under `dir` (recursively) whose name ends with `suffix` (any file for "").
fn files_under(dir: &Path, suffix: &str, found: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut paths: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n != "__pycache__") {
                files_under(&path, suffix, found);
            }
        } else if path.to_str().is_some_and(|p| p.ends_with(suffix)) {
            found.push(path);
        }
    }
}

/// What a user reads: the READMEs, the changelog, the docs, the Python package, the crates'
/// sources (their doc comments and `--help`), the experiment files, the results' arms files,
/// tools/, scripts/ and the Makefile.
fn user_facing_files() -> Vec<PathBuf> {
    let root = root();
    let mut files: Vec<PathBuf> = ["README.md", "CHANGELOG.md", "python/README.md", "Makefile"]
        .iter()
        .map(|f| root.join(f))
        .filter(|p| p.is_file())
        .collect();
    files_under(&root.join("docs"), ".md", &mut files);
    files_under(&root.join("python/defender_rl"), ".py", &mut files);
    files_under(&root.join("tools"), "", &mut files);
    files_under(&root.join("scripts"), "", &mut files);
    for entry in std::fs::read_dir(root.join("experiments")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            files.push(path);
        }
    }
    // The arms files the results pages' tables are made from (results/*/arms.txt and the like).
    for entry in std::fs::read_dir(root.join("results")).unwrap() {
        let Ok(listing) = std::fs::read_dir(entry.unwrap().path()) else { continue };
        let mut texts: Vec<PathBuf> = listing
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "txt"))
            .collect();
        texts.sort();
        files.extend(texts);
    }
    for entry in std::fs::read_dir(root.join("crates")).unwrap() {
        let krate = entry.unwrap().path();
        files_under(&krate.join("src"), ".rs", &mut files);
        if krate.join("README.md").is_file() {
            files.push(krate.join("README.md"));
        }
    }
    files
}

/// The 1-based lines on which `text` names a tracker issue by number: `issue 48`, `issues 33
/// and 34`, `issue #48`, `Issue 48`, as the regex `(?i)\bissues?\s+#?\d` would find them. The
/// whitespace may be a line break, and a comment's marker (`//`, `///`, `//!`, `#`, `*`) at the
/// start of the next line is skipped, so that a number wrapped onto the next line is caught too.
///
/// An upstream project's issue is cited as a URL (`https://github.com/owner/repo/issues/N`) or
/// as `owner/repo#N`; neither matches (no space follows "issues" in the URL), so those stay
/// allowed, and nothing else is.
fn issue_number_lines(text: &str) -> Vec<usize> {
    let lower = text.to_ascii_lowercase();
    let bytes = lower.as_bytes();
    let mut lines = Vec::new();
    let mut from = 0;
    while let Some(found) = lower[from..].find("issue") {
        let start = from + found;
        from = start + "issue".len();
        if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
            continue;
        }
        let mut at = from;
        if bytes.get(at) == Some(&b's') {
            at += 1;
        }
        let spaces_from = at;
        let mut crossed_line = false;
        loop {
            match bytes.get(at) {
                Some(b' ' | b'\t' | b'\r') => at += 1,
                Some(b'\n') => {
                    crossed_line = true;
                    at += 1;
                }
                Some(b'/' | b'!' | b'*' | b'#' | b'>') if crossed_line => at += 1,
                _ => break,
            }
        }
        if at == spaces_from {
            continue;
        }
        if bytes.get(at) == Some(&b'#') {
            at += 1;
        }
        if bytes.get(at).is_some_and(u8::is_ascii_digit) {
            lines.push(lower[..start].matches('\n').count() + 1);
        }
    }
    lines.dedup();
    lines
}

#[test]
fn issue_number_pattern_finds_what_it_should() {
    assert_eq!(issue_number_lines("as issue 48 chose"), [1]);
    assert_eq!(issue_number_lines("a\nIssues 33 and 34"), [2]);
    assert_eq!(issue_number_lines("see issue #48."), [1]);
    assert_eq!(issue_number_lines("ISSUE 7"), [1]);
    assert_eq!(issue_number_lines("the first arm of\nissue\n48"), [2]);
    assert_eq!(issue_number_lines("// what issue\n// 49 chose"), [1]);
    assert_eq!(issue_number_lines("issue 24's filter and issue 27's checks"), [1]);
    assert!(issue_number_lines("the issue is 48 steps; no issues; tissue 3").is_empty());
    assert!(issue_number_lines("https://github.com/PKU-Alignment/omnisafe/issues/312").is_empty());
    assert!(issue_number_lines("PKU-Alignment/omnisafe#312; issues: 3").is_empty());
}

/// Internal tracker numbers mean nothing to a reader outside the tracker: what users read names
/// the thing instead ("the repaired Lagrangian", "the first Lagrangian runs, `lagrangian-v1`").
#[test]
fn no_internal_issue_numbers_in_what_users_read() {
    let files = user_facing_files();
    assert!(files.len() > 50, "only {} files found", files.len());
    let mut found = Vec::new();
    for path in &files {
        let Ok(bytes) = std::fs::read(path) else { continue };
        let text = String::from_utf8_lossy(&bytes);
        let lines: Vec<&str> = text.lines().collect();
        for line in issue_number_lines(&text) {
            let shown = lines.get(line - 1).map_or("", |l| l.trim());
            let name = path.strip_prefix(root()).unwrap_or(path);
            found.push(format!("{}:{line}: {shown}", name.display()));
        }
    }
    assert!(
        found.is_empty(),
        "{} internal issue numbers in what users read (name the thing instead):\n{}",
        found.len(),
        found.join("\n")
    );
}
