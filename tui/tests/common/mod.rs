//! Helpers shared by the command-line tests (one set for every test file of this crate).
#![allow(dead_code)] // each test binary uses its own subset

use std::path::PathBuf;
use std::process::{Command, Output};

/// The `fringe` binary as a command to add arguments to.
pub fn fringe_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fringe"))
}

/// Runs the `fringe` binary with `args`.
pub fn fringe(args: &[&str]) -> Output {
    fringe_command().args(args).output().expect("run fringe")
}

/// Standard output then standard error, as text.
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// A fresh, empty scratch directory for one test (named for the test binary, the test and the
/// process, so parallel tests and runs never share one).
pub fn scratch(name: &str) -> PathBuf {
    let binary = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "test".into());
    let dir = std::env::temp_dir().join(format!("fringe-{binary}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}
