//! The shape of host-tool's source (issue #35): no import cycle among its modules and
//! no non-test source file over 800 lines; the module-graph checker and its own tests.
//!
//! The graph is read from the text: every path that names a module of the crate
//! (`crate::a::b::Item`, `super::x::Item`, `super::Item`, `self::x`, a declared child
//! `x::Item`, or a module brought in by `use`), in `use` trees and inline in code, is
//! an edge from the file's module to the deepest module the path walks into. So
//! `super::Name` is the sibling `Name` when the parent declares it, else the parent
//! (an item defined in or re-exported by it), and `pub use x::Y` in a mod.rs is an edge
//! to `x`. Declaring `mod x;` is no edge. Test-only code (`tests.rs`, `*_tests.rs`,
//! items under `#[cfg(test)]`), comments and string literals are not read.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt::Write as _;
use std::path::Path;

/// Longest non-test source file, in lines.
const MAX_LINES: usize = 800;

/// A module: its path segments below the crate root (empty for the root).
type Module = Vec<String>;

/// The module graph: every module, and each edge with where it was first seen.
#[derive(Debug, Default)]
struct Graph {
    modules: BTreeSet<Module>,
    /// from -> to -> "file:line: path" (the first place the dependency is named).
    edges: BTreeMap<Module, BTreeMap<Module, String>>,
}

/// An import cycle: the modules of one strongly connected component and one path
/// around it (first module repeated at the end), each step with its evidence.
#[derive(Debug)]
struct Cycle {
    modules: Vec<Module>,
    path: Vec<(Module, Module, String)>,
}

fn name(m: &Module) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

/// Files compiled only for tests (included under `#[cfg(test)]` by their parents).
fn is_test_file(rel: &str) -> bool {
    let file = rel.rsplit('/').next().unwrap_or(rel);
    file == "tests.rs" || file.ends_with("_tests.rs")
}

/// The module a library file defines (`lib.rs` the root, `a/mod.rs` and `a.rs` `a`);
/// `None` for the binary's `main.rs`.
fn module_of(rel: &str) -> Option<Module> {
    let stem = rel.strip_suffix(".rs")?;
    if stem == "main" {
        return None;
    }
    let mut m: Module = stem.split('/').map(String::from).collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib")) {
        m.pop();
    }
    Some(m)
}

/// The text with comments, string and char literals blanked (newlines kept, so line
/// numbers hold): a path in a doc comment or a message is no dependency.
fn strip(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied();
        if c[i] == '/' && at(i + 1) == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
                out.push(' ');
            }
        } else if c[i] == '/' && at(i + 1) == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == Some('*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == Some('/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if (c[i] == 'r' || (c[i] == 'b' && at(i + 1) == Some('r')))
            && (i == 0 || !ident(c[i - 1]))
            && {
                let mut k = i + if c[i] == 'b' { 2 } else { 1 };
                while c.get(k) == Some(&'#') {
                    k += 1;
                }
                c.get(k) == Some(&'"')
            }
        {
            // A raw string: r"..", r#".."#, br#".."#.
            let begin = i;
            let start = i + if c[i] == 'b' { 2 } else { 1 };
            let hashes = (start..).take_while(|&k| c.get(k) == Some(&'#')).count();
            i = start + hashes + 1;
            out.push_str(&" ".repeat(i - begin));
            while i < c.len() {
                if c[i] == '"' && (1..=hashes).all(|h| c.get(i + h) == Some(&'#')) {
                    out.push_str(&" ".repeat(hashes + 1));
                    i += hashes + 1;
                    break;
                }
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '"' {
            out.push(' ');
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            out.push(' ');
            i += 1;
        } else if c[i] == '\'' && (at(i + 1) == Some('\\') || at(i + 2) == Some('\'')) {
            // A char literal ('x', '\n', '\u{..}'), not a lifetime.
            out.push(' ');
            i += 1;
            if c[i] == '\\' {
                out.push(' ');
                i += 1;
            }
            while i < c.len() && c[i] != '\'' {
                out.push(' ');
                i += 1;
            }
            out.push(' ');
            i += 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// One token of stripped text: an identifier (keywords included), `::`, or any other
/// single character, with its line.
#[derive(Debug, Clone, PartialEq)]
struct Tok {
    text: String,
    line: usize,
}

fn tokens(text: &str) -> Vec<Tok> {
    let c: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch.is_alphanumeric() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok {
                text: c[start..i].iter().collect(),
                line,
            });
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(Tok {
                text: "::".into(),
                line,
            });
            i += 2;
        } else {
            out.push(Tok {
                text: ch.to_string(),
                line,
            });
            i += 1;
        }
    }
    out
}

/// The tokens without the items under `#[cfg(test)]` (a `mod tests { .. }`, a test
/// helper, a `mod tests;`).
fn without_test_items(toks: Vec<Tok>) -> Vec<Tok> {
    let is = |k: usize, s: &str| toks.get(k).is_some_and(|t| t.text == s);
    let mut out = Vec::with_capacity(toks.len());
    let mut i = 0;
    while i < toks.len() {
        let cfg_test = ["#", "[", "cfg", "(", "test", ")", "]"]
            .iter()
            .enumerate()
            .all(|(k, s)| is(i + k, s));
        if !cfg_test {
            out.push(toks[i].clone());
            i += 1;
            continue;
        }
        i += 7;
        // The item: up to its `;` or through its `{ .. }` block, whichever comes
        // first at depth 0 (further attributes and a `(..)` are passed over).
        let mut depth = 0i32;
        while i < toks.len() {
            match toks[i].text.as_str() {
                "(" | "[" => depth += 1,
                ")" | "]" => depth -= 1,
                ";" if depth == 0 => {
                    i += 1;
                    break;
                }
                "{" if depth == 0 => {
                    let mut braces = 0;
                    while i < toks.len() {
                        match toks[i].text.as_str() {
                            "{" => braces += 1,
                            "}" => braces -= 1,
                            _ => {}
                        }
                        i += 1;
                        if braces == 0 {
                            break;
                        }
                    }
                    break;
                }
                _ => {}
            }
            i += 1;
        }
    }
    out
}

fn is_ident(t: &Tok) -> bool {
    t.text
        .chars()
        .next()
        .is_some_and(|c| c.is_alphanumeric() || c == '_')
}

/// Expands the use tree at `toks[*i]` (after `use`) into full paths, each with the name
/// it binds (`None` for a glob).
fn use_tree(
    toks: &[Tok],
    i: &mut usize,
    prefix: Vec<String>,
    out: &mut Vec<(Vec<String>, Option<String>)>,
) {
    let mut path = prefix;
    while *i < toks.len() {
        let t = toks[*i].text.as_str();
        match t {
            "::" => *i += 1,
            "*" => {
                *i += 1;
                out.push((path, None));
                return;
            }
            "{" => {
                *i += 1;
                while *i < toks.len() && toks[*i].text != "}" {
                    use_tree(toks, i, path.clone(), out);
                    if toks.get(*i).is_some_and(|t| t.text == ",") {
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            _ if is_ident(&toks[*i]) => {
                path.push(t.to_string());
                *i += 1;
                if toks.get(*i).is_some_and(|t| t.text == "::") {
                    continue;
                }
                let mut bound = if t == "self" {
                    path.pop();
                    path.last().cloned()
                } else {
                    Some(t.to_string())
                };
                if toks.get(*i).is_some_and(|t| t.text == "as") {
                    bound = toks.get(*i + 1).map(|t| t.text.clone());
                    *i += 2;
                }
                out.push((path, bound));
                return;
            }
            _ => {
                // `;`, `}` or `,` of an enclosing group: nothing more here.
                return;
            }
        }
    }
}

/// Where `path`, named in module `from`, leads: the deepest module it walks into, or
/// `None` when it does not start in this crate (std, another crate, a local type).
fn resolve(
    modules: &BTreeSet<Module>,
    aliases: &BTreeMap<String, Module>,
    from: &Module,
    path: &[String],
) -> Option<Module> {
    let first = path.first()?.as_str();
    let child = |m: &Module, seg: &str| {
        let mut c = m.clone();
        c.push(seg.to_string());
        modules.contains(&c).then_some(c)
    };
    let (mut cur, rest) = match first {
        "crate" => (Vec::new(), &path[1..]),
        "self" => (from.clone(), &path[1..]),
        "super" => {
            let mut cur = from.clone();
            let mut k = 0;
            while path.get(k).is_some_and(|s| s == "super") {
                cur.pop()?;
                k += 1;
            }
            (cur, &path[k..])
        }
        _ => {
            if let Some(c) = child(from, first) {
                (c, &path[1..])
            } else {
                (aliases.get(first)?.clone(), &path[1..])
            }
        }
    };
    for seg in rest {
        match child(&cur, seg) {
            Some(c) => cur = c,
            None => break,
        }
    }
    Some(cur)
}

/// The module graph of `files` (path under src/ with '/', text); test files skipped.
fn graph(files: &[(String, String)]) -> Graph {
    let mut g = Graph::default();
    let sources: Vec<(&String, Module, Vec<Tok>)> = files
        .iter()
        .filter(|(rel, _)| !is_test_file(rel))
        .filter_map(|(rel, text)| {
            let m = module_of(rel)?;
            Some((rel, m, without_test_items(tokens(&strip(text)))))
        })
        .collect();
    g.modules = sources.iter().map(|(_, m, _)| m.clone()).collect();
    for (rel, from, toks) in &sources {
        let mut named: Vec<(Vec<String>, usize)> = Vec::new();
        let mut aliases: BTreeMap<String, Module> = BTreeMap::new();
        let mut in_use = vec![false; toks.len()];
        // `use` trees first: they also bind module names used inline below.
        let mut i = 0;
        while i < toks.len() {
            if toks[i].text == "use" {
                let (start, line) = (i, toks[i].line);
                i += 1;
                let mut paths = Vec::new();
                use_tree(toks, &mut i, Vec::new(), &mut paths);
                for f in in_use.iter_mut().take(i.min(toks.len())).skip(start) {
                    *f = true;
                }
                for (path, bound) in paths {
                    if let (Some(b), Some(m)) = (&bound, resolve(&g.modules, &aliases, from, &path))
                    {
                        let whole = path.last().is_some_and(|l| m.last() == Some(l));
                        if whole && b != "_" {
                            aliases.insert(b.clone(), m);
                        }
                    }
                    named.push((path, line));
                }
            } else {
                i += 1;
            }
        }
        // Inline paths: `a::b::c` not inside a `use`, not the tail of a longer path.
        let mut i = 0;
        while i < toks.len() {
            let starts = !in_use[i]
                && is_ident(&toks[i])
                && toks.get(i + 1).is_some_and(|t| t.text == "::")
                && (i == 0 || toks[i - 1].text != "::");
            if !starts {
                i += 1;
                continue;
            }
            let line = toks[i].line;
            let mut path = vec![toks[i].text.clone()];
            i += 1;
            while toks.get(i).is_some_and(|t| t.text == "::")
                && toks.get(i + 1).is_some_and(is_ident)
            {
                path.push(toks[i + 1].text.clone());
                i += 2;
            }
            named.push((path, line));
        }
        for (path, line) in named {
            let Some(to) = resolve(&g.modules, &aliases, from, &path) else {
                continue;
            };
            if &to != from {
                g.edges
                    .entry(from.clone())
                    .or_default()
                    .entry(to)
                    .or_insert_with(|| format!("{rel}:{line}: {}", path.join("::")));
            }
        }
    }
    g
}

/// Every cycle: each strongly connected component of more than one module (Tarjan),
/// with the shortest path around it from its first module.
fn cycles(g: &Graph) -> Vec<Cycle> {
    struct Tarjan<'a> {
        g: &'a Graph,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on_stack: BTreeSet<&'a Module>,
        sccs: Vec<Vec<Module>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a Module) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            self.on_stack.insert(v);
            let g: &'a Graph = self.g;
            for w in g.edges.get(v).into_iter().flat_map(|e| e.keys()) {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if self.on_stack.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut scc = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack.remove(w);
                    scc.push(w.clone());
                    if w == v {
                        break;
                    }
                }
                scc.sort();
                self.sccs.push(scc);
            }
        }
    }
    let mut t = Tarjan {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        sccs: Vec::new(),
    };
    let all: BTreeSet<&Module> = g.modules.iter().chain(g.edges.keys()).collect();
    for v in all {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    let mut out: Vec<Cycle> = t
        .sccs
        .into_iter()
        .filter(|s| s.len() > 1)
        .map(|scc| {
            let inside: BTreeSet<&Module> = scc.iter().collect();
            let start = &scc[0];
            // Breadth first from `start` back to it, within the component.
            let mut prev: BTreeMap<&Module, &Module> = BTreeMap::new();
            let mut queue = VecDeque::from([start]);
            let mut last = start;
            'search: while let Some(v) = queue.pop_front() {
                for w in g.edges.get(v).into_iter().flat_map(|e| e.keys()) {
                    if w == start {
                        last = v;
                        break 'search;
                    }
                    if inside.contains(w) && !prev.contains_key(w) {
                        prev.insert(w, v);
                        queue.push_back(w);
                    }
                }
            }
            let mut nodes = vec![start.clone(), last.clone()];
            let mut v = last;
            while v != start {
                v = prev[v];
                nodes.push(v.clone());
            }
            nodes.reverse();
            let path = nodes
                .windows(2)
                .map(|w| (w[0].clone(), w[1].clone(), g.edges[&w[0]][&w[1]].clone()))
                .collect();
            Cycle { modules: scc, path }
        })
        .collect();
    out.sort_by(|a, b| a.modules.cmp(&b.modules));
    out
}

/// The cycles in words: the modules, then each step around one with where it is named.
fn describe(cycles: &[Cycle]) -> String {
    let mut s = String::new();
    for c in cycles {
        let names: Vec<String> = c.modules.iter().map(name).collect();
        let _ = writeln!(
            s,
            "import cycle among {} modules: {}",
            names.len(),
            names.join(", ")
        );
        for (a, b, why) in &c.path {
            let _ = writeln!(s, "  {} -> {}   ({why})", name(a), name(b));
        }
    }
    s
}

/// Every .rs file under `dir`, as (path relative to `dir` with '/', text).
fn read_tree(dir: &Path) -> Vec<(String, String)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, String)>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(root, &p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root).unwrap();
                let rel: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                let text = std::fs::read_to_string(&p).unwrap();
                out.push((rel.join("/"), text));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out
}

/// host-tool's own source files.
fn host_tool_src() -> Vec<(String, String)> {
    read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

/// Non-test files over [`MAX_LINES`], as "path: N lines".
fn long_files(files: &[(String, String)]) -> Vec<String> {
    files
        .iter()
        .filter(|(rel, _)| !is_test_file(rel))
        .filter(|(_, text)| text.lines().count() > MAX_LINES)
        .map(|(rel, text)| format!("src/{rel}: {} lines", text.lines().count()))
        .collect()
}

#[test]
fn host_tool_has_no_import_cycle_and_no_long_file() {
    let files = host_tool_src();
    let found = cycles(&graph(&files));
    let long = long_files(&files);
    println!("{}", describe(&found));
    for l in &long {
        println!("over {MAX_LINES} lines: {l}");
    }
    assert!(
        found.is_empty() && long.is_empty(),
        "{} import cycle(s), {} file(s) over {MAX_LINES} lines:\n{}{}",
        found.len(),
        long.len(),
        describe(&found),
        long.join("\n")
    );
}

/// The layers (docs/layout.md, "Allowed dependencies"): each top-level module of the
/// library and the top-level modules it may import. The command-line layer (`cli`) is
/// the top: nothing imports it. `text` and `outfile` are the bottom.
const ALLOWED: &[(&str, &[&str])] = &[
    ("text", &[]),
    ("outfile", &[]),
    ("memory", &[]),
    ("pool", &[]),
    ("appearance", &[]),
    ("sweep_file", &["outfile", "text"]),
    ("fit", &["sweep_file", "text"]),
    ("calibrate", &["sweep_file", "plot", "outfile", "text"]),
    ("request", &["fit", "calibrate", "sweep_file", "text"]),
    (
        "campaign",
        &[
            "fit",
            "request",
            "calibrate",
            "sweep_file",
            "outfile",
            "text",
        ],
    ),
    ("device", &["sweep_file", "calibrate", "text"]),
    (
        "capture",
        &["device", "fit", "sweep_file", "outfile", "text"],
    ),
    ("live", &["capture", "fit", "sweep_file", "text"]),
    ("plot", &["fit", "sweep_file", "outfile", "text"]),
    ("export", &["fit", "sweep_file", "outfile", "text"]),
    ("import", &["export", "sweep_file", "outfile", "text"]),
    (
        "bench",
        &[
            "campaign",
            "capture",
            "device",
            "fit",
            "plot",
            "request",
            "sweep_file",
            "uncertainty",
            "outfile",
            "text",
        ],
    ),
    ("flash", &["outfile", "text"]),
    (
        "uncertainty",
        &[
            "appearance",
            "calibrate",
            "export",
            "fit",
            "sweep_file",
            "text",
        ],
    ),
    (
        "testing",
        &["capture", "device", "fit", "sweep_file", "text"],
    ),
    (
        "cli",
        &[
            "appearance",
            "bench",
            "calibrate",
            "campaign",
            "capture",
            "device",
            "export",
            "fit",
            "flash",
            "import",
            "live",
            "memory",
            "outfile",
            "plot",
            "pool",
            "request",
            "sweep_file",
            "text",
            "uncertainty",
        ],
    ),
];

/// Edges against the layers that still hold. Each must still exist: a break mended is
/// taken off this list. None since issue 50's front door (`request`, `campaign` above
/// `fit`).
const KNOWN_BREAKS: &[(&str, &str)] = &[];

/// The edges between top-level modules (the crate root left out), with evidence.
fn top_level_edges(g: &Graph) -> BTreeMap<(String, String), String> {
    let mut out = BTreeMap::new();
    for (from, to) in &g.edges {
        for (dest, why) in to {
            let (Some(a), Some(b)) = (from.first(), dest.first()) else {
                continue;
            };
            if a != b {
                out.entry((a.clone(), b.clone()))
                    .or_insert_with(|| why.clone());
            }
        }
    }
    out
}

/// Issue 50: the layering written down (docs/layout.md) and checked: every import
/// between top-level modules is allowed or a known break; Python never links the
/// command-line layer except where listed.
#[test]
fn host_tool_keeps_its_layers() {
    let edges = top_level_edges(&graph(&host_tool_src()));
    let allowed = |a: &str, b: &str| {
        ALLOWED
            .iter()
            .any(|(from, to)| *from == a && to.contains(&b))
    };
    let wrong: Vec<String> = edges
        .iter()
        .filter(|((a, b), _)| !allowed(a, b) && !KNOWN_BREAKS.contains(&(a.as_str(), b.as_str())))
        .map(|((a, b), why)| format!("{a} -> {b} ({why})"))
        .collect();
    assert!(
        wrong.is_empty(),
        "imports against the layers:\n{}",
        wrong.join("\n")
    );
    for (a, b) in KNOWN_BREAKS {
        assert!(
            edges.contains_key(&(a.to_string(), b.to_string())),
            "{a} -> {b} no longer exists: take it off KNOWN_BREAKS"
        );
        assert!(!allowed(a, b));
    }
    let doc = std::fs::read_to_string(crate::util::repo_root().join("docs/layout.md")).unwrap();
    for (from, to) in ALLOWED {
        let line = format!(
            "| `{from}` | {} |",
            if to.is_empty() {
                "nothing".to_string()
            } else {
                to.iter()
                    .map(|t| format!("`{t}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        );
        assert!(
            doc.contains(&line),
            "docs/layout.md should hold the row '{line}'"
        );
    }
    // Python's binding never links the command-line layer.
    let py = crate::util::repo_root().join("python/src");
    let mut cli_uses = Vec::new();
    for (rel, text) in read_tree(&py) {
        for (k, line) in text.lines().enumerate() {
            if line.contains("gonio::cli") {
                cli_uses.push(format!("python/src/{rel}:{}", k + 1));
            }
        }
    }
    assert!(
        cli_uses.is_empty(),
        "Python links the command-line layer: {cli_uses:?}"
    );
}

fn files(list: &[(&str, &str)]) -> Vec<(String, String)> {
    list.iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect()
}

fn m(s: &str) -> Module {
    s.split("::").map(String::from).collect()
}

#[test]
fn a_cycle_through_grouped_uses_inline_paths_and_super_is_found() {
    let g = graph(&files(&[
        ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\n"),
        (
            "a.rs",
            "use crate::{b::{self, Item as B}, a};\npub struct Thing;\n",
        ),
        (
            "b.rs",
            "pub struct Item;\npub fn f() {\n    crate::c::g();\n}\n",
        ),
        (
            "c.rs",
            "pub fn g() -> super::a::Thing {\n    super::a::Thing\n}\n",
        ),
    ]));
    let found = cycles(&g);
    assert_eq!(found.len(), 1, "{}", describe(&found));
    assert_eq!(found[0].modules, vec![m("a"), m("b"), m("c")]);
    let steps: Vec<String> = found[0]
        .path
        .iter()
        .map(|(a, b, why)| format!("{} -> {} ({why})", name(a), name(b)))
        .collect();
    assert_eq!(
        steps,
        [
            "a -> b (a.rs:1: crate::b)",
            "b -> c (b.rs:3: crate::c::g)",
            "c -> a (c.rs:1: super::a::Thing)",
        ]
    );
}

#[test]
fn super_names_a_sibling_or_the_parent_and_test_code_is_not_read() {
    let tree = [
        ("lib.rs", "pub mod p;\n"),
        (
            "p/mod.rs",
            "pub mod x;\npub mod y;\npub use y::Z;\npub struct T;\n\
             #[cfg(test)]\nmod tests {\n    use super::x::*;\n}\n",
        ),
        (
            "p/x.rs",
            "// super::y::Z in a comment\nuse super::T;\n\
             fn f() -> &'static str { \"self::y::Z\" }\nfn c() -> char { '\"' }\n",
        ),
        (
            "p/y.rs",
            "pub struct Z;\n#[cfg(test)]\nmod tests {\n    use super::super::x::*;\n}\n",
        ),
        ("p/y_tests.rs", "use crate::p::x;\n"),
    ];
    let g = graph(&files(&tree));
    let edges: Vec<(String, String)> = g
        .edges
        .iter()
        .flat_map(|(a, to)| to.keys().map(move |b| (name(a), name(b))))
        .collect();
    assert_eq!(
        edges,
        [("p".into(), "p::y".into()), ("p::x".into(), "p".into())]
    );
    assert!(cycles(&g).is_empty());
    // A child naming what its parent re-exports from it (through the parent) is a cycle.
    let mut tree = tree.to_vec();
    tree[3].1 = "pub struct Z;\npub fn f(_: &super::T) {}\n";
    let found = cycles(&graph(&files(&tree)));
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].modules, vec![m("p"), m("p::y")]);
}

#[test]
fn long_files_are_counted_but_test_files_exempt() {
    let long = "\n".repeat(MAX_LINES + 1);
    let found = long_files(&files(&[
        ("a/b.rs", long.as_str()),
        ("a/b_tests.rs", long.as_str()),
        ("a/tests.rs", long.as_str()),
        ("a/c.rs", "fn f() {}\n"),
    ]));
    assert_eq!(found, [format!("src/a/b.rs: {} lines", MAX_LINES + 1)]);
}
