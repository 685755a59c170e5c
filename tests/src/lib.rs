//! Helpers shared by the workspace integration tests (one set, used by every test file).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::Command;

/// The Python interpreter with the independent peers of `tests/python/requirements.txt`
/// installed: `FRINGE_PYTHON` (set by scripts/test to .venv/bin/python), else `python3`.
pub fn python() -> String {
    std::env::var("FRINGE_PYTHON").unwrap_or_else(|_| "python3".to_string())
}

/// Panics with what to do unless `module` can be imported by [`python`].
pub fn require_python_module(module: &str) {
    let check = Command::new(python())
        .args(["-c", &format!("import {module}")])
        .output()
        .expect("run the Python interpreter (FRINGE_PYTHON or python3)");
    assert!(
        check.status.success(),
        "{module} is not importable by {}: run scripts/test (it installs tests/python/requirements.txt into .venv and sets FRINGE_PYTHON)",
        python()
    );
}

/// A Python peer script of `tests/python/`.
pub fn python_script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("python")
        .join(name)
}

/// 127.0.0.1 on a port the system chooses.
pub fn loopback() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 0))
}
