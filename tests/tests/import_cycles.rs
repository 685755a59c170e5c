//! No import circle between files (docs/architecture.md).
//!
//! For every crate of the workspace (libraries, binaries, integration tests, examples) this reads
//! the module tree from the crate root (`mod name;`, `#[path = "..."]`, inline `mod name { .. }`),
//! then every `use` statement that names a module of the same crate (`crate::..`, `super::..`,
//! `self::..`, or a child module by name), and every such path written inline in the code
//! (`crate::bench::limits(..)`, `super::failure::Kind::Stall`, in macro arguments too), and draws an
//! edge from the file holding it to the file of the deepest module the path names. A cycle in that graph fails the test, naming the
//! files and the `use` lines that close it. Re-exports count: `pub use child::X` in a parent is an
//! edge from the parent to the child, so a child must import from its siblings, not through the
//! parent (nor the crate root).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

#[test]
fn no_import_cycle_between_files() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ is inside the workspace")
        .to_path_buf();
    let roots = crate_roots(&workspace);
    assert!(roots.len() > 10, "found only {roots:?}");
    let mut report = String::new();
    let (mut files, mut edges) = (0, 0);
    for root in &roots {
        let graph = Crate::read(root);
        files += graph.files.values().map(Vec::len).sum::<usize>();
        edges += graph.edges().values().map(|to| to.len()).sum::<usize>();
        for cycle in graph.cycles() {
            report.push_str(&format!(
                "import circle in the crate of {}:\n",
                rel(&workspace, root)
            ));
            for (from, to, line, text) in cycle {
                report.push_str(&format!(
                    "  {}:{line}: `{text}` -> {}\n",
                    rel(&workspace, &from),
                    rel(&workspace, &to)
                ));
            }
        }
    }
    // The parser must see the workspace: a few hundred files and more edges than that.
    assert!(files > 200 && edges > 200, "{files} files, {edges} edges");
    assert!(
        report.is_empty(),
        "{report}import from the module that defines an item (a sibling file, not the parent or the \
         crate root that re-exports it), or move what both files need into a module of its own"
    );
}

/// The cycles of a scratch crate whose root `lib.rs` declares `pub mod a; pub mod b;`, with
/// `a.rs`, `a/inner.rs` and `b.rs` holding `a`, `inner` and `b`.
fn cycles_of(
    name: &str,
    a: &str,
    inner: &str,
    b: &str,
) -> Vec<Vec<(PathBuf, PathBuf, usize, String)>> {
    let dir = std::env::temp_dir().join(format!("fringe-import-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("a")).expect("scratch dir");
    for (file, text) in [
        ("lib.rs", "pub mod a;\npub mod b;\n"),
        ("a.rs", a),
        ("a/inner.rs", inner),
        ("b.rs", b),
    ] {
        fs::write(dir.join(file), text).expect("write");
    }
    let cycles = Crate::read(&dir.join("lib.rs")).cycles();
    let _ = fs::remove_dir_all(&dir);
    cycles
}

#[test]
fn a_circle_through_a_parent_re_export_is_found() {
    let cycles = cycles_of(
        "re-export",
        "mod inner;\npub use inner::Thing;\n",
        "use crate::b::{self, Other};\npub struct Thing;\n",
        "// use crate::nothing;\nuse super::a::Thing;\npub struct Other;\n#[cfg(test)]\nmod tests {\n    use super::*;\n}\n",
    );
    assert_eq!(cycles.len(), 1, "{cycles:?}");
    let files: BTreeSet<String> = cycles[0]
        .iter()
        .map(|(from, _, _, _)| from.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(files, ["a.rs", "b.rs", "inner.rs"].map(String::from).into());
}

#[test]
fn a_circle_through_an_inline_path_is_found() {
    let cycles = cycles_of(
        "inline",
        "pub mod inner;\npub fn f() -> u8 { inner::g() + crate::b::h() }\n",
        "pub fn g() -> u8 { std::cmp::max(1, fringe_rig::a::x()) }\n",
        "pub fn h() -> u8 {\n    let _ = format!(\"{}\", super::a::f());\n    2\n}\n",
    );
    assert_eq!(cycles.len(), 1, "{cycles:?}");
    let mut lines: Vec<(String, usize, String)> = cycles[0]
        .iter()
        .map(|(from, _, line, text)| {
            let name = from.file_name().unwrap().to_string_lossy().into_owned();
            (name, *line, text.clone())
        })
        .collect();
    lines.sort();
    assert_eq!(
        lines,
        [
            ("a.rs", 2, "pub fn f() -> u8 { inner::g() + crate::b::h() }"),
            ("b.rs", 2, "let _ = format!(\"{}\", super::a::f());"),
        ]
        .map(|(f, l, t)| (f.to_string(), l, t.to_string()))
    );
}

fn rel(workspace: &Path, p: &Path) -> String {
    p.strip_prefix(workspace).unwrap_or(p).display().to_string()
}

/// The root file of every target of every workspace member.
fn crate_roots(workspace: &Path) -> Vec<PathBuf> {
    let manifest = fs::read_to_string(workspace.join("Cargo.toml")).expect("workspace Cargo.toml");
    let members = manifest
        .split_once("members")
        .and_then(|(_, rest)| rest.split_once('['))
        .and_then(|(_, rest)| rest.split_once(']'))
        .map(|(list, _)| list)
        .expect("workspace members");
    let mut roots = Vec::new();
    for member in members.split(',') {
        let member = member.trim().trim_matches('"');
        if member.is_empty() {
            continue;
        }
        let dir = workspace.join(member);
        for root in ["src/lib.rs", "src/main.rs"] {
            if dir.join(root).is_file() {
                roots.push(dir.join(root));
            }
        }
        for targets in ["src/bin", "tests", "examples", "benches"] {
            let Ok(entries) = fs::read_dir(dir.join(targets)) else {
                continue;
            };
            let mut files: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "rs"))
                .collect();
            files.sort();
            roots.extend(files);
        }
    }
    roots
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    Str(String),
    /// `::`
    Path,
    Punct(char),
}

/// Tokens of a Rust file with their line numbers: identifiers, string contents, `::` and single
/// punctuation; comments, character literals and lifetimes dropped.
fn tokens(text: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied();
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    line += usize::from(c[i] == '\n');
                    i += 1;
                }
            }
        } else if ch == '"' || ((ch == 'r' || ch == 'b') && starts_raw_or_byte_string(&c, i)) {
            // Plain, byte and raw strings: "...", b"...", r#"..."#, br"...".
            let start_line = line;
            if c[i] == 'b' {
                i += 1;
            }
            let raw = c[i] == 'r';
            if raw {
                i += 1;
            }
            let mut hashes = 0;
            while c[i] == '#' {
                hashes += 1;
                i += 1;
            }
            i += 1; // the opening quote
            let mut s = String::new();
            while i < c.len() {
                if !raw && c[i] == '\\' {
                    line += usize::from(c.get(i + 1) == Some(&'\n'));
                    i += 2;
                    continue;
                }
                if c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#')) {
                    i += 1 + hashes;
                    break;
                }
                line += usize::from(c[i] == '\n');
                s.push(c[i]);
                i += 1;
            }
            out.push((Tok::Str(s), start_line));
        } else if ch == '\'' {
            // A character literal ('x', '\n', '\u{1F600}') or a lifetime ('a).
            if next == Some('\\') {
                i += 3; // the quote, the backslash and the escaped character
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
                while i < c.len() && ident(c[i]) {
                    i += 1;
                }
            }
        } else if ident(ch) {
            let start = i;
            while i < c.len() && ident(c[i]) {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            out.push((Tok::Ident(word), line));
        } else if ch == ':' && next == Some(':') {
            out.push((Tok::Path, line));
            i += 2;
        } else {
            out.push((Tok::Punct(ch), line));
            i += 1;
        }
    }
    out
}

/// True if `c[i..]` starts a raw string (`r"`, `r#"`, `br"`) or a byte string (`b"`), and `c[i]`
/// does not continue an identifier.
fn starts_raw_or_byte_string(c: &[char], i: usize) -> bool {
    if i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_') {
        return false;
    }
    let mut j = i;
    if c[j] == 'b' {
        j += 1;
        if c.get(j) == Some(&'"') {
            return true;
        }
    }
    if c.get(j) != Some(&'r') {
        return false;
    }
    j += 1;
    while c.get(j) == Some(&'#') {
        j += 1;
    }
    c.get(j) == Some(&'"')
}

/// One `use` statement: the module path it stands in, its line and text, and the paths it names.
struct Use {
    module: Vec<String>,
    line: usize,
    text: String,
    paths: Vec<Vec<String>>,
}

/// A crate's files, modules and `use` statements.
struct Crate {
    /// Module path -> the files that hold it (two for a module declared under exclusive cfgs).
    files: BTreeMap<Vec<String>, Vec<PathBuf>>,
    /// Inline modules -> the file they are written in.
    inline: BTreeMap<Vec<String>, PathBuf>,
    uses: Vec<(PathBuf, Use)>,
}

impl Crate {
    fn read(root: &Path) -> Crate {
        let mut krate = Crate {
            files: BTreeMap::new(),
            inline: BTreeMap::new(),
            uses: Vec::new(),
        };
        krate.read_file(
            root,
            Vec::new(),
            root.parent().expect("root dir").to_path_buf(),
        );
        krate
    }

    /// Reads `file`, the module `module`, whose child module files live in `child_dir`.
    fn read_file(&mut self, file: &Path, module: Vec<String>, child_dir: PathBuf) {
        let Ok(text) = fs::read_to_string(file) else {
            return;
        };
        let entry = self.files.entry(module.clone()).or_default();
        if entry.iter().any(|f| f == file) {
            return;
        }
        entry.push(file.to_path_buf());
        let toks = tokens(&text);
        let lines: Vec<&str> = text.lines().collect();
        // Brace stack: Some(name) for the brace of an inline module.
        let mut braces: Vec<Option<String>> = Vec::new();
        let mut pending_inline: Option<String> = None;
        let mut children = Vec::new();
        let mut i = 0;
        while i < toks.len() {
            let here: Vec<String> = module
                .iter()
                .cloned()
                .chain(braces.iter().flatten().cloned())
                .collect();
            match &toks[i].0 {
                Tok::Punct('{') => braces.push(pending_inline.take()),
                Tok::Punct('}') => {
                    braces.pop();
                }
                Tok::Ident(w) if w == "mod" => {
                    if let Some((Tok::Ident(name), _)) = toks.get(i + 1) {
                        match toks.get(i + 2).map(|t| &t.0) {
                            Some(Tok::Punct(';')) => {
                                let path_attr = path_attribute(&toks, i);
                                let in_inline = braces.iter().flatten().next().is_some();
                                // A `#[path]` outside inline modules is relative to the file's
                                // own directory; everything else to the module's directory.
                                let dir = if path_attr.is_some() && !in_inline {
                                    file.parent().expect("file dir").to_path_buf()
                                } else {
                                    braces
                                        .iter()
                                        .flatten()
                                        .fold(child_dir.clone(), |d, m| d.join(m))
                                };
                                children.push((here.clone(), name.clone(), path_attr, dir));
                            }
                            Some(Tok::Punct('{')) => {
                                let mut path = here.clone();
                                path.push(name.clone());
                                self.inline.insert(path, file.to_path_buf());
                                pending_inline = Some(name.clone());
                            }
                            _ => {}
                        }
                    }
                }
                Tok::Ident(w) if w == "use" && is_item_start(&toks, i) => {
                    let end = (i..toks.len())
                        .find(|&k| toks[k].0 == Tok::Punct(';'))
                        .unwrap_or(toks.len());
                    let line = toks[i].1;
                    let mut paths = Vec::new();
                    use_tree(&toks[i + 1..end], &mut 0, &[], &mut paths);
                    self.uses.push((
                        file.to_path_buf(),
                        Use {
                            module: here,
                            line,
                            text: lines.get(line - 1).map_or("", |l| l.trim()).to_string(),
                            paths,
                        },
                    ));
                    i = end;
                }
                // A path written inline (`crate::sim::limits(..)`, `super::x::Y`,
                // `child::f()`), not the tail of a longer path (`other_crate::child::f`).
                Tok::Ident(first)
                    if toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Path)
                        && (i == 0 || toks[i - 1].0 != Tok::Path) =>
                {
                    let line = toks[i].1;
                    let mut path = vec![first.clone()];
                    while let (Some(Tok::Path), Some(Tok::Ident(next))) =
                        (toks.get(i + 1).map(|t| &t.0), toks.get(i + 2).map(|t| &t.0))
                    {
                        path.push(next.clone());
                        i += 2;
                    }
                    self.uses.push((
                        file.to_path_buf(),
                        Use {
                            module: here,
                            line,
                            text: lines.get(line - 1).map_or("", |l| l.trim()).to_string(),
                            paths: vec![path],
                        },
                    ));
                }
                _ => {}
            }
            i += 1;
        }
        for (parent, name, path_attr, dir) in children {
            let mut child = parent;
            child.push(name.clone());
            let (child_file, grandchild_dir) = match path_attr {
                Some(p) => {
                    let f = dir.join(&p);
                    let d = f.with_extension("");
                    (f, d)
                }
                None if dir.join(format!("{name}.rs")).is_file() => {
                    (dir.join(format!("{name}.rs")), dir.join(&name))
                }
                None => (dir.join(&name).join("mod.rs"), dir.join(&name)),
            };
            self.read_file(&child_file, child, grandchild_dir);
        }
    }

    /// The file of the deepest module `path` (crate-relative) names.
    fn file_of(&self, path: &[String]) -> Vec<PathBuf> {
        for n in (0..=path.len()).rev() {
            let prefix = &path[..n];
            if let Some(files) = self.files.get(prefix) {
                return files.clone();
            }
            if let Some(file) = self.inline.get(prefix) {
                return vec![file.clone()];
            }
        }
        Vec::new()
    }

    fn is_module(&self, path: &[String]) -> bool {
        self.files.contains_key(path) || self.inline.contains_key(path)
    }

    /// File -> file edges, each with the line and text of its first `use`.
    fn edges(&self) -> BTreeMap<PathBuf, BTreeMap<PathBuf, (usize, String)>> {
        let mut edges: BTreeMap<PathBuf, BTreeMap<PathBuf, (usize, String)>> = BTreeMap::new();
        for (file, u) in &self.uses {
            for path in &u.paths {
                let Some(first) = path.first() else { continue };
                let full: Vec<String> = match first.as_str() {
                    "crate" => path[1..].to_vec(),
                    "self" => u.module.iter().chain(&path[1..]).cloned().collect(),
                    "super" => {
                        let ups = path.iter().take_while(|s| *s == "super").count();
                        if ups > u.module.len() {
                            continue;
                        }
                        u.module[..u.module.len() - ups]
                            .iter()
                            .chain(&path[ups..])
                            .cloned()
                            .collect()
                    }
                    _ => {
                        let mut child = u.module.clone();
                        child.push(first.clone());
                        if !self.is_module(&child) {
                            continue; // another crate, or an item in scope
                        }
                        u.module.iter().chain(path).cloned().collect()
                    }
                };
                for to in self.file_of(&full) {
                    if &to != file {
                        edges
                            .entry(file.clone())
                            .or_default()
                            .entry(to)
                            .or_insert_with(|| (u.line, u.text.clone()));
                    }
                }
            }
        }
        edges
    }

    /// Every strongly connected group of more than one file, as the edges inside it.
    fn cycles(&self) -> Vec<Vec<(PathBuf, PathBuf, usize, String)>> {
        let edges = self.edges();
        let nodes: BTreeSet<&PathBuf> = edges
            .iter()
            .flat_map(|(f, to)| std::iter::once(f).chain(to.keys()))
            .collect();
        let reach = |from: &PathBuf| -> BTreeSet<PathBuf> {
            let mut seen = BTreeSet::new();
            let mut stack = vec![from.clone()];
            while let Some(f) = stack.pop() {
                for to in edges.get(&f).into_iter().flat_map(|m| m.keys()) {
                    if seen.insert(to.clone()) {
                        stack.push(to.clone());
                    }
                }
            }
            seen
        };
        let reachable: BTreeMap<&PathBuf, BTreeSet<PathBuf>> =
            nodes.iter().map(|n| (*n, reach(n))).collect();
        let mut done = BTreeSet::new();
        let mut out = Vec::new();
        for n in &nodes {
            if done.contains(*n) || !reachable[n].contains(*n) {
                continue;
            }
            let group: BTreeSet<PathBuf> = reachable[n]
                .iter()
                .filter(|m| reachable.get(m).is_some_and(|r| r.contains(*n)))
                .cloned()
                .collect();
            let mut cycle = Vec::new();
            for from in &group {
                for (to, (line, text)) in edges.get(from).into_iter().flatten() {
                    if group.contains(to) {
                        cycle.push((from.clone(), to.clone(), *line, text.clone()));
                    }
                }
            }
            done.extend(group);
            out.push(cycle);
        }
        out
    }
}

/// True if the token at `i` starts an item (not, say, a field named `use`).
fn is_item_start(toks: &[(Tok, usize)], i: usize) -> bool {
    match i.checked_sub(1).map(|k| &toks[k].0) {
        None => true,
        Some(Tok::Punct(';' | '{' | '}' | ']' | ')')) => true,
        Some(Tok::Ident(w)) => w == "pub",
        _ => false,
    }
}

/// The `#[path = "..."]` attribute among the attributes before the `mod` at `i`.
fn path_attribute(toks: &[(Tok, usize)], i: usize) -> Option<String> {
    let mut j = i;
    // Visibility: pub, pub(crate), pub(super), pub(in path).
    if j > 0 && toks[j - 1].0 == Tok::Punct(')') {
        while j > 0 && toks[j - 1].0 != Tok::Punct('(') {
            j -= 1;
        }
        j = j.saturating_sub(1);
    }
    if j > 0 && toks[j - 1].0 == Tok::Ident("pub".into()) {
        j -= 1;
    }
    let mut found = None;
    while j >= 2 && toks[j - 1].0 == Tok::Punct(']') {
        let close = j - 1;
        let mut depth = 0;
        let mut open = close;
        loop {
            match toks[open].0 {
                Tok::Punct(']') => depth += 1,
                Tok::Punct('[') => depth -= 1,
                _ => {}
            }
            if depth == 0 || open == 0 {
                break;
            }
            open -= 1;
        }
        if let [(Tok::Ident(p), _), (Tok::Punct('='), _), (Tok::Str(s), _)] = &toks[open + 1..close]
        {
            if p == "path" {
                found = Some(s.clone());
            }
        }
        if open == 0 || toks[open - 1].0 != Tok::Punct('#') {
            break;
        }
        j = open - 1;
    }
    found
}

/// Expands a use tree (`a::b::{c, d::{self, e}}`, globs, renames) into paths, `*` and `self`
/// ending a path at its prefix.
fn use_tree(toks: &[(Tok, usize)], at: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
    let mut path = prefix.to_vec();
    if *at < toks.len() && toks[*at].0 == Tok::Path {
        // `::name`: an extern crate.
        path.push("::".into());
        *at += 1;
    }
    loop {
        match toks.get(*at).map(|t| &t.0) {
            Some(Tok::Ident(w)) if w == "as" => {
                *at += 2; // `as name`
                out.push(path);
                return;
            }
            Some(Tok::Ident(w)) => {
                if w != "self" || path.is_empty() {
                    path.push(w.clone());
                }
                *at += 1;
            }
            Some(Tok::Punct('*')) => {
                *at += 1;
                out.push(path);
                return;
            }
            Some(Tok::Punct('{')) => {
                *at += 1;
                loop {
                    match toks.get(*at).map(|t| &t.0) {
                        None => return,
                        Some(Tok::Punct('}')) => {
                            *at += 1;
                            return;
                        }
                        Some(Tok::Punct(',')) => *at += 1,
                        Some(_) => use_tree(toks, at, &path, out),
                    }
                }
            }
            Some(Tok::Path) => *at += 1,
            _ => {
                out.push(path);
                return;
            }
        }
    }
}
