//! What the documentation says about the repository holds: every section it cites by heading
//! exists, every document it cites exists, and the experiment files with committed runs name
//! the profile they were made with, as docs/cli.md says.
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
