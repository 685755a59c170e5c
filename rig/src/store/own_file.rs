//! A run holds its own files: regular files inside its directory. A symbolic link (to a file or
//! to `frames/`) would make the run depend on files elsewhere, and a FIFO, socket or device would
//! block a reader for ever (`runs`, `verify`, `export` read every file of a run): both are
//! refused with an error naming the file, before anything is opened.

use std::io;
use std::path::{Component, Path};

/// Checks that `rel` (a path relative to the run directory `dir`) names a regular file with no
/// symbolic link on the way from `dir`. A missing file is `NotFound`, as `File::open` says it.
pub fn check_in(dir: &Path, rel: &Path) -> io::Result<()> {
    let mut here = dir.to_path_buf();
    let parts: Vec<Component> = rel.components().collect();
    for (k, part) in parts.iter().enumerate() {
        here.push(part);
        let meta = std::fs::symlink_metadata(&here)?;
        let kind = meta.file_type();
        if kind.is_symlink() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "is a symbolic link: a run holds its own files, not links to others (copy the file into the run)",
            ));
        }
        let last = k + 1 == parts.len();
        if last && !kind.is_file() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "is not a regular file (a FIFO, a socket, a device or a directory): a run's files are regular files",
            ));
        }
    }
    Ok(())
}

/// Checks that `path`, a file directly in a run directory, is a regular file (see [`check_in`]).
pub fn check(path: &Path) -> io::Result<()> {
    match (path.parent(), path.file_name()) {
        (Some(dir), Some(name)) => check_in(dir, Path::new(name)),
        _ => Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "is not a file of a run",
        )),
    }
}

/// Reads a file of a run that [`check`] accepts.
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    check(path)?;
    std::fs::read(path)
}

/// Reads a text file of a run that [`check`] accepts.
pub fn read_to_string(path: &Path) -> io::Result<String> {
    check(path)?;
    std::fs::read_to_string(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifos_and_links_are_refused_without_being_opened() {
        let dir = std::env::temp_dir().join(format!("fringe-own-file-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("real")).expect("dir");
        std::fs::write(dir.join("real/a.png"), b"x").expect("file");
        std::fs::write(dir.join("plain.json"), b"{}").expect("file");
        std::os::unix::fs::symlink(dir.join("real"), dir.join("frames")).expect("link");
        std::os::unix::fs::symlink(dir.join("plain.json"), dir.join("linked.json")).expect("link");
        let fifo = dir.join("frames.jsonl");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo");
        assert!(made.success());
        assert!(read(&dir.join("plain.json")).is_ok());
        let e = read_to_string(&fifo).expect_err("a FIFO");
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let e = read(&dir.join("linked.json")).expect_err("a link");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        let e = check_in(&dir, Path::new("frames/a.png")).expect_err("a linked frames/");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert_eq!(
            check(&dir.join("absent.json")).expect_err("absent").kind(),
            io::ErrorKind::NotFound
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
