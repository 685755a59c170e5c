//! Helpers shared by the workspace integration tests (one set, used by every test file).

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
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

/// Every file under `dir` (relative path, content), to show that something changed nothing.
pub fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(here) = stack.pop() {
        for entry in std::fs::read_dir(&here).expect("read dir") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(dir)
                    .expect("inside")
                    .display()
                    .to_string();
                out.insert(rel, std::fs::read(&path).expect("read"));
            }
        }
    }
    out
}

/// The fake `libnidaqmx.so` of `tests/fake-nidaqmx` (a workspace member, so `cargo test` and
/// `cargo nextest run --workspace` build it beside the test binaries).
pub fn fake_nidaqmx() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let mut dir = exe.parent().map(Path::to_path_buf).unwrap_or_default();
    if dir.ends_with("deps") {
        dir.pop();
    }
    let lib = dir.join("libnidaqmx.so");
    assert!(
        lib.exists(),
        "{} is missing: build it with `cargo build -p fringe-fake-nidaqmx` (scripts/test builds it before the tests)",
        lib.display()
    );
    lib
}
