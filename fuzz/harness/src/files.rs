//! Targets over readers that take a path: model files and run directories. The input is written
//! to a scratch directory of this process first (on tmpfs when there is one).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fringe_rig::store;

/// This process's scratch directory.
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        remove_left_behind(&base);
        let dir = base.join(format!("fringe-fuzz-{}", std::process::id()));
        if let Err(e) = std::fs::create_dir_all(&dir) {
            panic!(
                "cannot create the fuzz scratch directory {}: {e}",
                dir.display()
            );
        }
        dir
    })
}

/// Removes the scratch directories of fuzz processes that have ended: a process's directory
/// lives as long as the process (a static is never dropped), so each new one clears those left
/// behind (on Linux, where `/proc` says which processes run).
fn remove_left_behind(base: &Path) {
    if !Path::new("/proc/self").is_dir() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(base) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix("fringe-fuzz-"))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

fn write(path: &Path, bytes: &[u8]) {
    if let Err(e) = std::fs::write(path, bytes) {
        panic!("cannot write the fuzz input to {}: {e}", path.display());
    }
}

/// A model file as `fringe model` opens it: the first byte picks the file name's extension
/// (`.pth`, `.pt`, `.safetensors`, `.onnx`), the rest is the file. Weights are read, and the
/// whole model opened (architecture recognised, ONNX graph checked).
pub fn model_file(data: &[u8]) {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let ext = ["pth", "pt", "safetensors", "onnx"][usize::from(pick % 4)];
    let path = scratch().join(format!("model.{ext}"));
    write(&path, bytes);
    let _ = fringe_sensor_models::detect_format(&path);
    let _ = fringe_sensor_models::read_weights(&path);
    let _ = fringe_sensor_models::Model::open(&path);
}

/// A run directory as `fringe runs`, `fringe verify` and calibration read it. The input holds
/// the run's files in this order, separated by 0xFF bytes (which none of the text files can
/// hold): start.json, frames.jsonl, stop.json, checkpoint.json, then force.bin (the rest).
pub fn run_dir(data: &[u8]) {
    let root = scratch().join("runs");
    let dir = root.join("run");
    if let Err(e) = std::fs::create_dir_all(&dir) {
        panic!("cannot create {}: {e}", dir.display());
    }
    let run = store::RunReader::at(&dir);
    let files = [
        store::RunFile::Start,
        store::RunFile::Frames,
        store::RunFile::Stop,
        store::RunFile::Checkpoint,
        store::RunFile::Force,
    ];
    let mut parts = data.splitn(files.len(), |b| *b == 0xFF);
    for file in files {
        let path = run.path(file);
        match parts.next() {
            Some(bytes) if !bytes.is_empty() => write(&path, bytes),
            _ => {
                let _ = std::fs::remove_file(&path);
            }
        }
    }
    let _ = store::verify_run(&dir);
    let _ = store::list_runs(&root);
    let _ = fringe_calibration::ScanRun::read(&dir);
}
