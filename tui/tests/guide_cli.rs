//! The user guide (docs/, an mdBook) and README.md cannot drift from the tool:
//!
//! - every `fringe` command written out in the guide or the README (in a `sh` or `console` block,
//!   or as inline code in the text) is one the binary takes (its subcommands, flags and values parse: `fringe ARGS... --help`
//!   succeeds); synopsis lines (`[--rig FILE]`, `a|b`, `<run-id>`, `...`) are not commands and are
//!   left out;
//! - the tour (docs/guide/tour.md) runs: each `$ fringe ...` of its `console` blocks, in order, in
//!   one fresh directory on the simulated bench, must succeed and print the lines shown under it,
//!   in that order (other lines may come between; `...` in a shown line stands for any text).

mod common;

use common::scratch;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One command of the guide: where it is written and the command line after `fringe`.
struct Example {
    file: PathBuf,
    line: usize,
    command: String,
    /// Written as `$ fringe ...` in a `console` block: a command to run, not only to read.
    in_console: bool,
    /// What the guide shows it printing (`console` blocks only).
    shown: Vec<String>,
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tui/ is inside the workspace")
        .to_path_buf()
}

/// The guide's pages: every Markdown file under docs/ (the book's sources), and README.md.
fn pages() -> Vec<PathBuf> {
    let root = workspace();
    let mut pages = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(dir) = dirs.pop() {
        let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        for entry in entries {
            let path = entry.expect("docs entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                pages.push(path);
            }
        }
    }
    pages.sort();
    pages
}

/// The commands in `sh` and `console` blocks of `text` (a page's contents), and in its inline
/// code spans.
fn examples_in(file: &Path, text: &str) -> Vec<Example> {
    let mut examples: Vec<Example> = Vec::new();
    let mut block: Option<&str> = None;
    let mut block_start = 0;
    let mut pending = String::new();
    let mut pending_line = 0;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if let Some(info) = trimmed.strip_prefix("```") {
            block = match block {
                Some(_) => None,
                None => Some(info.split([',', ' ']).next().unwrap_or("")),
            };
            block_start = examples.len();
            continue;
        }
        let Some(kind) = block else {
            // In prose, a command is an inline code span: `fringe ...`.
            for span in line.split('`').skip(1).step_by(2) {
                push_commands(&mut examples, file, k + 1, span, false);
            }
            continue;
        };
        if kind != "sh" && kind != "console" {
            continue;
        }
        // A `\` at the end continues the command on the next line.
        if !pending.is_empty() {
            pending.push(' ');
            pending.push_str(trimmed.trim_end_matches('\\').trim());
            if !trimmed.ends_with('\\') {
                push_commands(
                    &mut examples,
                    file,
                    pending_line,
                    &pending,
                    kind == "console",
                );
                pending.clear();
            }
            continue;
        }
        let command = if kind == "console" {
            match trimmed.strip_prefix("$ ") {
                Some(c) => c,
                None => {
                    if examples.len() > block_start && !trimmed.is_empty() {
                        if let Some(last) = examples.last_mut() {
                            last.shown.push(trimmed.to_string());
                        }
                    }
                    continue;
                }
            }
        } else {
            trimmed
        };
        if trimmed.ends_with('\\') {
            pending = command.trim_end_matches('\\').trim().to_string();
            pending_line = k + 1;
        } else {
            push_commands(&mut examples, file, k + 1, command, kind == "console");
        }
    }
    examples
}

/// Adds each `fringe` command of `line` (commands joined by `&&` are taken one by one; a `#`
/// comment is dropped; `cargo run --release [--features F] --` counts as `fringe`).
fn push_commands(
    examples: &mut Vec<Example>,
    file: &Path,
    line: usize,
    text: &str,
    in_console: bool,
) {
    let text = match text.find(" #") {
        Some(k) => &text[..k],
        None => text,
    };
    for part in text.split("&&") {
        let part = part.trim();
        // `cargo run --release [--features F] -- ARGS` runs fringe; other packages' examples do not.
        let after_cargo = part
            .strip_prefix("cargo run --release")
            .and_then(|rest| rest.split_once("-- "))
            .filter(|(options, _)| !options.contains("-p ") && !options.contains("--example"))
            .map(|(_, args)| args.to_string());
        let command = match (after_cargo, part.strip_prefix("fringe")) {
            (Some(args), _) => args,
            (None, Some(rest)) if rest.is_empty() || rest.starts_with(' ') => {
                rest.trim().to_string()
            }
            _ => continue,
        };
        examples.push(Example {
            file: file.to_path_buf(),
            line,
            command,
            in_console,
            shown: Vec::new(),
        });
    }
}

/// Whether `command` is a synopsis (optional parts, alternatives, placeholders), not a command.
fn is_synopsis(command: &str) -> bool {
    let mut quoted = false;
    for c in command.chars() {
        match c {
            '"' | '\'' => quoted = !quoted,
            '[' | ']' | '|' | '<' | '>' | '…' if !quoted => return true,
            _ => {}
        }
    }
    command.contains("...")
}

/// The words of a command line as a POSIX shell splits them (quotes, no expansion).
fn words(command: &str) -> Vec<String> {
    shlex::split(command).unwrap_or_else(|| panic!("unbalanced quotes in `{command}`"))
}

/// Commands of the features this test binary was built without are left out of the parse check.
fn needs_missing_feature(file: &Path, command: &str) -> bool {
    let aravis = command.contains("--aravis");
    let torch = command.starts_with("train ") || command.contains("--fine-tune");
    let _ = file;
    (aravis && !cfg!(feature = "aravis")) || (torch && !cfg!(feature = "torch"))
}

#[test]
fn every_fringe_command_in_the_guide_is_one_the_binary_takes() {
    let root = workspace();
    let mut checked = 0;
    let mut refused = String::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("guide page");
        for example in examples_in(&page, &text) {
            if is_synopsis(&example.command) || needs_missing_feature(&page, &example.command) {
                continue;
            }
            // A span that names a flag (`fringe eval --spec`) is checked against the command's
            // help: the flag must be one of its options.
            let mut args = words(&example.command);
            let named_flag = match args.last() {
                Some(last) if last.starts_with("--") && example.shown.is_empty() => args.pop(),
                _ => None,
            };
            let out = Command::new(env!("CARGO_BIN_EXE_fringe"))
                .args(&args)
                .arg("--help")
                .output()
                .expect("run fringe --help");
            checked += 1;
            let help = String::from_utf8_lossy(&out.stdout);
            let flag_known = named_flag.as_ref().is_none_or(|flag| {
                help.contains(&format!("{flag} ")) || help.contains(&format!("{flag}\n"))
            });
            if !out.status.success() || !flag_known {
                refused.push_str(&format!(
                    "{}:{}: `fringe {}`\n{}\n",
                    example
                        .file
                        .strip_prefix(&root)
                        .unwrap_or(&example.file)
                        .display(),
                    example.line,
                    example.command,
                    match (&named_flag, out.status.success()) {
                        (Some(flag), true) => format!("its help lists no option {flag}"),
                        _ => String::from_utf8_lossy(&out.stderr).trim().to_string(),
                    }
                ));
            }
        }
    }
    assert!(
        refused.is_empty(),
        "commands in the guide that fringe refuses:\n{refused}"
    );
    // The guide shows well over a hundred concrete commands; far fewer means the reader broke.
    assert!(checked > 100, "only {checked} commands found in the guide");
}

/// Whether `line` (one line of output) matches `shown` (a line of the guide, where `...` is any
/// text): the pieces between the `...` appear in order, the first at the start of the line
/// unless the shown line begins with `...`, the last at its end unless it ends with `...`.
fn matches(shown: &str, line: &str) -> bool {
    let pieces: Vec<&str> = shown.split("...").collect();
    let line = line.trim_end();
    let mut rest = line;
    for (k, piece) in pieces.iter().enumerate() {
        if k == 0 {
            match rest.strip_prefix(piece) {
                Some(r) => rest = r,
                None => return false,
            }
        } else if k == pieces.len() - 1 {
            return piece.is_empty() || rest.ends_with(piece);
        } else {
            match rest.find(piece) {
                Some(at) => rest = &rest[at + piece.len()..],
                None => return false,
            }
        }
    }
    rest.is_empty()
}

#[test]
fn the_tour_runs_on_the_simulated_bench() {
    let root = workspace();
    let page = root.join("docs/guide/tour.md");
    let text = std::fs::read_to_string(&page).expect("docs/guide/tour.md");
    let examples: Vec<Example> = examples_in(&page, &text)
        .into_iter()
        .filter(|e| e.in_console)
        .collect();
    assert!(
        examples.len() >= 10,
        "the tour shows {} commands",
        examples.len()
    );
    let dir = scratch("tour");
    // The tour runs from the repository's top directory: its plans and rig files are reached
    // through `tui/`.
    std::os::unix::fs::symlink(root.join("tui"), dir.join("tui")).expect("link tui/");
    let bin = Path::new(env!("CARGO_BIN_EXE_fringe"))
        .parent()
        .expect("the binary's directory");
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for example in examples {
        let out = Command::new("sh")
            .arg("-c")
            .arg(format!("exec 2>&1; fringe {}", example.command))
            .env("PATH", &path)
            .current_dir(&*dir)
            .output()
            .expect("run sh");
        let printed = String::from_utf8_lossy(&out.stdout).to_string();
        let where_ = format!(
            "docs/guide/tour.md:{}: `fringe {}`",
            example.line, example.command
        );
        assert!(out.status.success(), "{where_} failed:\n{printed}");
        let mut lines = printed.lines();
        for shown in example.shown.iter().filter(|s| s.as_str() != "...") {
            assert!(
                lines.any(|line| matches(shown, line)),
                "{where_} did not print, in this order, the line\n  {shown}\nit printed:\n{printed}"
            );
        }
    }
}

#[test]
fn a_shown_line_matches_with_its_ellipses_only() {
    assert!(matches("ok: every file", "ok: every file"));
    assert!(matches("Fz RMSE: ... N", "Fz RMSE:        0.3076 N"));
    assert!(!matches("Fz RMSE: ... N", "Fz RMSE:        0.3076 mm"));
    assert!(matches(
        "run written to runs/short-grid-...",
        "run written to runs/short-grid-1"
    ));
    assert!(!matches(
        "completed: 6 of 6 points",
        "completed: 5 of 6 points"
    ));
    assert!(matches("... N", "4 N"));
    assert!(!matches("wrote a", "wrote ab"));
    assert!(is_synopsis("scan PLAN [--rig rig.toml]"));
    assert!(is_synopsis("verify runs/<run-id>"));
    assert!(!is_synopsis("scan short.toml --rig \"a|b.toml\""));
}

/// The paths in inline code of `text` that start at a top-level directory of the workspace
/// (`rig/src/store/verify.rs`, `tui/app/rigs/paper-bench.toml`), with their line numbers.
fn paths_in(text: &str, top: &[String]) -> Vec<(usize, String)> {
    let mut paths = Vec::new();
    for (k, line) in text.lines().enumerate() {
        for span in line.split('`').skip(1).step_by(2) {
            for word in span.split([' ', '(', ')', ',', ':', '"', '\'', '=']) {
                let word = word.trim_end_matches('.');
                let first = word.split('/').next().unwrap_or("");
                let is_file = Path::new(word).extension().is_some_and(|e| {
                    ["rs", "toml", "md", "py", "txt", "sh", "json", "cal"]
                        .contains(&e.to_str().unwrap_or(""))
                });
                if word.contains('/')
                    && is_file
                    && top.iter().any(|t| t == first)
                    && !word.contains(['*', '<'])
                {
                    paths.push((k + 1, word.to_string()));
                }
            }
        }
    }
    paths
}

/// The `src/` folders of the workspace's crates (every folder holding a Cargo.toml and a src/).
fn crate_sources(root: &Path) -> Vec<PathBuf> {
    let mut sources = Vec::new();
    let mut dirs = vec![root.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        if dir.join("Cargo.toml").is_file() && dir.join("src").is_dir() {
            sources.push(dir.join("src"));
        }
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.filter_map(Result::ok) {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if entry.path().is_dir() && !name.starts_with('.') && name != "target" && name != "src"
            {
                dirs.push(entry.path());
            }
        }
    }
    sources
}

#[test]
fn every_file_the_guide_names_exists() {
    let root = workspace();
    let top: Vec<String> = std::fs::read_dir(&root)
        .expect("workspace")
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|name| !name.starts_with('.') && name != "target")
        .collect();
    let sources = crate_sources(&root);
    let mut missing = String::new();
    let mut named = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("guide page");
        for (line, path) in paths_in(&text, &top) {
            named += 1;
            // From the top of the repository, or (design notes name files inside a crate, such as
            // the application crate's `rig/force.rs`) from a crate's `src/`.
            let found =
                root.join(&path).exists() || sources.iter().any(|src| src.join(&path).exists());
            if !found {
                missing.push_str(&format!(
                    "{}:{line}: {path}\n",
                    page.strip_prefix(&root).unwrap_or(&page).display()
                ));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "files the guide names that are not in the repository:\n{missing}"
    );
    assert!(named > 50, "only {named} file paths found in the guide");
}
