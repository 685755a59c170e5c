//! A run holds its own files: regular files inside its directory. A symbolic link (to a file or
//! to `frames/`) would make the run depend on files elsewhere, and a FIFO, socket or device would
//! block a reader for ever (`runs`, `verify`, `export` read every file of a run): both are
//! refused with an error naming the file, before anything is opened.

use std::fs::{File, OpenOptions};
use std::io;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Component, Path};

const LINK: &str =
    "is a symbolic link: a run holds its own files, not links to others (copy the file into the run)";
const NOT_REGULAR: &str = "is not a regular file (a FIFO, a socket, a device or a directory): a run's files are regular files";

/// Checks that `rel` (a path relative to the run directory `dir`) names a regular file with no
/// symbolic link on the way from `dir`. A missing file is `NotFound`, as `File::open` says it.
pub(crate) fn check_in(dir: &Path, rel: &Path) -> io::Result<()> {
    let mut here = dir.to_path_buf();
    let parts: Vec<Component> = rel.components().collect();
    for (k, part) in parts.iter().enumerate() {
        here.push(part);
        let meta = std::fs::symlink_metadata(&here)?;
        let kind = meta.file_type();
        if kind.is_symlink() {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, LINK));
        }
        let last = k + 1 == parts.len();
        if last && !kind.is_file() {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, NOT_REGULAR));
        }
    }
    Ok(())
}

/// Checks that `path`, a file directly in a run directory, is a regular file (see [`check_in`]).
pub(crate) fn check(path: &Path) -> io::Result<()> {
    match (path.parent(), path.file_name()) {
        (Some(dir), Some(name)) => check_in(dir, Path::new(name)),
        _ => Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "is not a file of a run",
        )),
    }
}

/// Reads a file of a run that [`check`] accepts.
pub(crate) fn read(path: &Path) -> io::Result<Vec<u8>> {
    check(path)?;
    std::fs::read(path)
}

/// Reads a text file of a run that [`check`] accepts.
pub(crate) fn read_to_string(path: &Path) -> io::Result<String> {
    check(path)?;
    std::fs::read_to_string(path)
}

/// Opens a file of a run for writing with `options` (create, append, truncate as the caller
/// asks), never through a symbolic link (`O_NOFOLLOW`: the kernel refuses one at the last
/// component, so a link put in the file's place is never written through) and never blocking on
/// a FIFO; anything but a regular file is refused before a byte is written.
pub(crate) fn open_with(options: &mut OpenOptions, path: &Path) -> io::Result<File> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_symlink() => {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, LINK))
        }
        Ok(meta) if !meta.file_type().is_file() => {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, NOT_REGULAR))
        }
        Ok(_) => {}
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    // A link or FIFO put in its place between the look and the open is refused too.
    let file = options
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| match e.raw_os_error() {
            Some(libc::ELOOP) => io::Error::new(io::ErrorKind::InvalidInput, LINK),
            _ => e,
        })?;
    if !file.metadata()?.file_type().is_file() {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, NOT_REGULAR));
    }
    Ok(file)
}

/// Creates (or truncates) a file of a run for writing: [`open_with`] `create` + `truncate`.
pub(crate) fn create(path: &Path) -> io::Result<File> {
    open_with(
        OpenOptions::new().write(true).create(true).truncate(true),
        path,
    )
}

/// Opens a file of a run for appending, creating it: [`open_with`] `create` + `append`.
pub(crate) fn append(path: &Path) -> io::Result<File> {
    open_with(OpenOptions::new().create(true).append(true), path)
}

/// What is wrong with the entry `path` when it is not a regular file or a directory (`None`
/// when it is one, or is absent).
pub(crate) fn stranger(path: &Path) -> Option<&'static str> {
    let kind = std::fs::symlink_metadata(path).ok()?.file_type();
    if kind.is_symlink() {
        Some(LINK)
    } else if kind.is_file() || kind.is_dir() {
        None
    } else {
        Some(NOT_REGULAR)
    }
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
        // Written: never through the link (the file it points to keeps its bytes), never into
        // the FIFO (no blocking).
        let e = create(&dir.join("linked.json")).expect_err("a link");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        let e = append(&dir.join("linked.json")).expect_err("a link");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert_eq!(
            std::fs::read(dir.join("plain.json")).expect("target"),
            b"{}"
        );
        let e = append(&fifo).expect_err("a FIFO");
        assert!(e.to_string().contains("not a regular file"), "{e}");
        assert!(stranger(&dir.join("linked.json")).is_some());
        assert!(stranger(&fifo).is_some());
        assert!(stranger(&dir.join("plain.json")).is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
