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
    // One shell for the page's blocks, in order: later blocks use earlier files. The
    // README's tour runs twice, as a reader may run it again.
    let runs = if page == "README.md" { 2 } else { 1 };
    let mut script = String::new();
    for run in 1..=runs {
        for (line, body) in &blocks {
            script.push_str(&format!("echo '>>> {page}:{line} (run {run})' >&2\n{body}"));
        }
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
    if page == "README.md" {
        failures.extend(tour_leftovers(&d));
        let ignore = std::fs::read_to_string(root.join(".gitignore")).unwrap();
        if !ignore.lines().any(|l| l.trim() == "gonio-tour/") {
            failures.push("README.md: .gitignore does not ignore gonio-tour/".into());
        }
    }
    (blocks.len(), failures)
}

/// What the README's tour left outside `gonio-tour/` (ignored by git) in the scratch
/// directory that stands for the repository root: nothing, or `git status` shows it.
fn tour_leftovers(dir: &Path) -> Vec<String> {
    let page_dir_entries = ["bin", "host-tool", "python"];
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "gonio-tour" && !page_dir_entries.contains(&n.as_str()))
        .collect();
    left.sort();
    if left.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "README.md: the tour wrote outside gonio-tour/ (untracked in a clone): {}",
            left.join(" ")
        )]
    }
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

/// The code of a page: inline `code` spans, fenced blocks and indented blocks, one
/// string per span or command line (lines ending in `\` joined).
fn code_of(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    let mut pending = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced || line.starts_with("    ") {
            pending.push_str(line.trim_end().trim_end_matches('\\'));
            pending.push(' ');
            if !line.trim_end().ends_with('\\') {
                out.push(std::mem::take(&mut pending));
            }
            continue;
        }
        out.extend(
            line.split('`')
                .enumerate()
                .filter(|(i, _)| i % 2 == 1)
                .map(|(_, s)| s.to_string()),
        );
    }
    out
}

/// The flags `gonio CMD... --help` lists.
fn flags_of(cmd: &[&str]) -> std::collections::BTreeSet<String> {
    let out = crate::util::gonio_command()
        .args(cmd)
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success(), "gonio {cmd:?} --help failed");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(str::to_string)
        .collect()
}

/// The subcommands `gonio CMD... --help` lists.
fn subcommands_of(cmd: &[&str]) -> Vec<String> {
    let out = crate::util::gonio_command()
        .args(cmd)
        .arg("--help")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    text.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| *n != "help")
        .map(str::to_string)
        .collect()
}

/// Every `gonio` command and flag that README.md and docs/*.md name in code exists:
/// checked against the commands' `--help`.
#[test]
fn every_command_and_flag_the_docs_name_exists() {
    let root = repo_root();
    let mut pages = vec![root.join("README.md")];
    for e in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    pages.sort();
    let top = subcommands_of(&[]);
    let mut nested = std::collections::BTreeMap::new();
    let mut flags = std::collections::BTreeMap::new();
    let mut failures = Vec::new();
    let mut checked = 0;
    for page in &pages {
        let name = page.strip_prefix(&root).unwrap().display().to_string();
        let text = std::fs::read_to_string(page).unwrap();
        for code in code_of(&text) {
            // Each command in the span: from `gonio ` to the next pipe, `;`, `&&`,
            // redirection or comment.
            for (at, _) in code.match_indices("gonio ") {
                let before = &code[..at];
                // `# gonio sweep v1` (a file's line), `python -m gonio`, a path.
                if before.ends_with("# ")
                    || before.ends_with('/')
                    || before.ends_with('-')
                    || before.ends_with("import ")
                    || before.ends_with("-m ")
                {
                    continue;
                }
                let rest: Vec<&str> = code[at + "gonio ".len()..].split_whitespace().collect();
                // A synopsis's `| --flag` is an alternative, a shell's `| head` a pipe.
                let end = (0..rest.len())
                    .find(|&i| {
                        let t = rest[i];
                        (t == "|" && !rest.get(i + 1).is_some_and(|n| n.starts_with("--")))
                            || ["&&", "||", ";", "2>&1"].contains(&t)
                            || t.starts_with('>')
                            || t.starts_with('#')
                    })
                    .unwrap_or(rest.len());
                let words = &rest[..end];
                let Some(&sub) = words.first() else { continue };
                if !sub.chars().all(|c| c.is_ascii_lowercase()) {
                    continue;
                }
                if !top.iter().any(|t| t == sub) {
                    failures.push(format!("{name}: `gonio {sub}`: no such command ({code})"));
                    continue;
                }
                let mut cmd = vec![sub];
                let subs = nested
                    .entry(sub.to_string())
                    .or_insert_with(|| subcommands_of(&[sub]));
                if let Some(&second) = words.get(1)
                    && !subs.is_empty()
                {
                    if subs.iter().any(|s| s == second) {
                        cmd.push(second);
                    } else if second.chars().all(|c| c.is_ascii_lowercase()) {
                        failures.push(format!(
                            "{name}: `gonio {sub} {second}`: no such command ({code})"
                        ));
                        continue;
                    }
                }
                let known = flags.entry(cmd.join(" ")).or_insert_with(|| flags_of(&cmd));
                for w in &words[cmd.len()..] {
                    let w = w.trim_start_matches(['[', '(']);
                    let flag = w.split(['=', '[', ']', ',', '|']).next().unwrap_or("");
                    let flag = flag.trim_end_matches(['.', ':', ')']);
                    if flag.starts_with("--") && flag.len() > 2 && flag != "--" {
                        checked += 1;
                        if !known.contains(flag) {
                            failures.push(format!(
                                "{name}: `gonio {} {flag}`: no such flag ({code})",
                                cmd.join(" ")
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} flags found in the docs");
    failures.sort();
    failures.dedup();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
