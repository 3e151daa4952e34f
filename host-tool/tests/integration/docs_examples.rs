//! The examples of README.md and docs/*.md run as written: every block fenced as
//! ```` ```sh ```` on a page runs, in order, in one scratch directory per page, under
//! `bash -euo pipefail` with `gonio` the binary under test. Examples that need hardware
//! or a network (flashing, `pip install`, `cargo xtask`) are indented blocks, not run.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{repo_root, scratch};

/// The pages by task that must show at least one example that runs.
const TASK_PAGES: [&str; 8] = [
    "README.md",
    "docs/capture.md",
    "docs/fitting.md",
    "docs/units.md",
    "docs/formats.md",
    "docs/python-and-mitsuba.md",
    "docs/PERFORMANCE.md",
    "docs/RELIABILITY.md",
];

/// Longest a page's examples may take together (a hung example fails, not hangs).
const PAGE_LIMIT_S: u32 = 300;

/// The ```` ```sh ```` blocks of `text`: the line each starts on (1-based) and its body.
fn shell_blocks(text: &str) -> Vec<(usize, String)> {
    let mut blocks = Vec::new();
    let mut open: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        match &mut open {
            None if line.trim_end() == "```sh" => open = Some((i + 1, String::new())),
            None => {}
            Some(_) if line.trim_end() == "```" => blocks.extend(open.take()),
            Some((_, body)) => {
                body.push_str(line);
                body.push('\n');
            }
        }
    }
    assert!(open.is_none(), "a ```sh block is never closed");
    blocks
}

/// A scratch directory where a page's examples see what they would from the
/// repository root (its data, the Python package) and write only into the scratch
/// directory; `bin/gonio` is the binary under test.
fn page_dir(root: &Path) -> (crate::util::Scratch, PathBuf) {
    let d = scratch("docs");
    for shared in ["host-tool", "python"] {
        std::os::unix::fs::symlink(root.join(shared), d.join(shared)).unwrap();
    }
    let bin = d.join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_gonio"), bin.join("gonio")).unwrap();
    (d, bin)
}

/// Runs the examples of `page` (relative to the repository root); the failures, each
/// naming its page and line.
fn run_page(root: &Path, page: &str) -> (usize, Vec<String>) {
    let text = std::fs::read_to_string(root.join(page)).unwrap();
    let blocks = shell_blocks(&text);
    let (d, bin) = page_dir(root);
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // One shell for the page's blocks, in order: later blocks use earlier files.
    let mut script = String::new();
    for (line, body) in &blocks {
        script.push_str(&format!("echo '>>> {page}:{line}' >&2\n{body}"));
    }
    let out = Command::new("timeout")
        .arg(PAGE_LIMIT_S.to_string())
        .args(["bash", "-euo", "pipefail", "-c", &script])
        .current_dir(&*d)
        .env("PATH", path)
        .output()
        .unwrap();
    let mut failures = Vec::new();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let at = err
            .lines()
            .rfind(|l| l.starts_with(">>> "))
            .unwrap_or("(before the first block)")
            .to_string();
        failures.push(format!(
            "{page}: the block at {at} failed ({}):\n{}",
            out.status,
            err.lines().rev().take(15).collect::<Vec<_>>().join("\n")
        ));
    }
    (blocks.len(), failures)
}

#[test]
fn every_pages_shell_examples_run_as_written() {
    let root = repo_root();
    let mut pages: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    pages.sort();
    pages.insert(0, "README.md".into());
    let results: Vec<(String, usize, Vec<String>)> = std::thread::scope(|s| {
        let runs: Vec<_> = pages
            .iter()
            .map(|p| {
                let root = &root;
                s.spawn(move || {
                    let (n, f) = run_page(root, p);
                    (p.clone(), n, f)
                })
            })
            .collect();
        runs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut failures = Vec::new();
    for (page, n, f) in results {
        if TASK_PAGES.contains(&page.as_str()) && n == 0 {
            failures.push(format!("{page}: no ```sh example"));
        }
        failures.extend(f);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn shell_blocks_are_found_and_other_blocks_left_alone() {
    let text = "intro\n```sh\ngonio a\ngonio b\n```\n```python\nx = 1\n```\n    gonio indented\n```sh\ngonio c\n```\n";
    assert_eq!(
        shell_blocks(text),
        [
            (2, "gonio a\ngonio b\n".to_string()),
            (10, "gonio c\n".to_string())
        ]
    );
}
