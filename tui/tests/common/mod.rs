//! Helpers shared by the command-line tests.

use std::process::{Command, Output};

/// Runs the `fringe` binary with `args`.
pub fn fringe(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fringe"))
        .args(args)
        .output()
        .expect("run fringe")
}

/// Standard output then standard error, as text.
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}
