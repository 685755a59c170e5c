//! One writer per run: a lock held on `RUN/.lock` for as long as a process writes the run (a
//! scan, a resume, the UI's scan, the close of a cut-short run), and a shared lock for readers
//! that need the run to stand still while they read it whole (export, evaluation).
//!
//! The lock is an advisory `flock` on the file, which the kernel releases when the holder's
//! process ends however it ends: a lock left by a process that was killed is free, and the next
//! writer takes it over without asking anyone to delete anything. The file holds the writer's
//! pid, command line and start time, so a refusal names the holder. It is not part of the run:
//! the manifest and `fringe verify` pass it over, and a writer removes it when it is done.
//!
//! The lock file is fringe's own regular file: one that is a symbolic link (or a FIFO, a device)
//! is refused, never opened through, so a link planted as `RUN/.lock` cannot make a writer
//! write its pid into (or a reader empty) the file it points to.

use super::documents::now_utc;
use super::error::StoreError;
use super::own_file;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// The lock file's name inside a run directory.
pub(crate) const LOCK: &str = ".lock";

/// How a lock is held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// One writer, no reader.
    Write,
    /// Readers together, no writer.
    Read,
}

/// A lock on a run, released when dropped.
#[derive(Debug)]
pub struct RunLock {
    file: File,
    path: PathBuf,
    mode: Mode,
}

impl RunLock {
    /// Takes the run in `dir` for writing; refused while another process writes or reads it.
    pub fn write(dir: &Path) -> Result<RunLock, StoreError> {
        let mut lock = RunLock::take(dir, Mode::Write)?;
        let holder = format!(
            "pid {}: {} (since {})\n",
            std::process::id(),
            command_line(),
            now_utc()
        );
        let path = lock.path.clone();
        lock.file
            .set_len(0)
            .and_then(|()| lock.file.rewind())
            .and_then(|()| lock.file.write_all(holder.as_bytes()))
            .map_err(|e| StoreError::io(&path, e))?;
        Ok(lock)
    }

    /// Takes the run in `dir` for reading; refused while a process writes it. A run whose
    /// directory cannot be written (read-only media) cannot be written by anyone either: it is
    /// read without a lock.
    pub fn read(dir: &Path) -> Result<Option<RunLock>, StoreError> {
        match RunLock::take(dir, Mode::Read) {
            Ok(lock) => Ok(Some(lock)),
            Err(StoreError::Io { source, .. })
                if matches!(
                    source.kind(),
                    std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }

    fn take(dir: &Path, mode: Mode) -> Result<RunLock, StoreError> {
        let path = dir.join(LOCK);
        // The file may be removed by a writer finishing between our open and our lock: the
        // lock then sits on a file nobody else will open. Check and take the new one.
        for _ in 0..8 {
            let mut file = own_file::open_with(
                OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create(true)
                    .truncate(false),
                &path,
            )
            .map_err(|e| refused(&path, e))?;
            let op = match mode {
                Mode::Write => libc::LOCK_EX,
                Mode::Read => libc::LOCK_SH,
            };
            // SAFETY: flock on a file descriptor this function owns; no memory is passed.
            let rc = unsafe { libc::flock(file.as_raw_fd(), op | libc::LOCK_NB) };
            if rc != 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() != std::io::ErrorKind::WouldBlock {
                    return Err(StoreError::io(&path, e));
                }
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                return Err(StoreError::Busy {
                    dir: dir.to_path_buf(),
                    holder: holder_text(&holder, mode),
                });
            }
            let same = match (file.metadata(), std::fs::symlink_metadata(&path)) {
                (Ok(held), Ok(now)) => held.ino() == now.ino() && held.dev() == now.dev(),
                _ => false,
            };
            if same {
                if mode == Mode::Read {
                    // Whatever a writer left in it (a writer killed) is stale now.
                    let _ = file.set_len(0);
                }
                return Ok(RunLock { file, path, mode });
            }
        }
        Err(StoreError::Content {
            path,
            message: "the lock file keeps being replaced: another process is opening and closing this run; try again".into(),
        })
    }
}

/// The error of a lock file that cannot be opened; one that is not fringe's own regular file (a
/// link, a FIFO) says what to do.
fn refused(path: &Path, e: std::io::Error) -> StoreError {
    if e.kind() == std::io::ErrorKind::InvalidInput {
        StoreError::Content {
            path: path.to_path_buf(),
            message: format!(
                "{e}; a run's lock file is a regular file fringe makes and removes: nothing was \
                 written through it; remove it (what it points to is not touched by removing \
                 it) and try again"
            ),
        }
    } else {
        StoreError::io(path, e)
    }
}

/// Who is writing the run in `dir` now: the holder named in its lock file (`pid N: command
/// (since ...)`) while a process holds the run for writing; `None` when none does (a lock file
/// left by a killed writer, one held by readers only, or none at all). The lock is only looked
/// at: a shared lock taken and dropped at once, on a lock file that is a regular file.
pub(crate) fn writer(dir: &Path) -> Option<String> {
    let mut file = own_file::open_with(OpenOptions::new().read(true), &dir.join(LOCK)).ok()?;
    // SAFETY: flock on a file descriptor this function owns; no memory is passed.
    let rc = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_SH | libc::LOCK_NB) };
    if rc == 0 {
        return None;
    }
    if std::io::Error::last_os_error().kind() != std::io::ErrorKind::WouldBlock {
        return None;
    }
    let mut holder = String::new();
    let _ = file.read_to_string(&mut holder);
    let holder = holder.trim();
    Some(if holder.is_empty() {
        "another process".into()
    } else {
        holder.to_string()
    })
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // The file goes while the lock is still held (a process that opened it meanwhile finds
        // it replaced, see `take`): by a writer, and by the last reader (the one that can turn
        // its shared lock into the only one).
        let last = match self.mode {
            Mode::Write => true,
            // SAFETY: flock on the file descriptor this lock owns; no memory is passed.
            Mode::Read => unsafe {
                libc::flock(self.file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) == 0
            },
        };
        if last {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Who holds the lock, from the file's text (empty when only readers hold it).
fn holder_text(text: &str, wanted: Mode) -> String {
    let text = text.trim();
    if !text.is_empty() {
        format!("it is being written by another process, {text}")
    } else if wanted == Mode::Write {
        "another fringe process is reading it whole (an export or an evaluation)".into()
    } else {
        "another process is writing it".into()
    }
}

fn command_line() -> String {
    let mut args = std::env::args();
    let program = args
        .next()
        .map(|p| {
            Path::new(&p)
                .file_name()
                .map_or(p.clone(), |n| n.to_string_lossy().into_owned())
        })
        .unwrap_or_default();
    std::iter::once(program)
        .chain(args)
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("fringe-lock-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch");
        dir
    }

    #[test]
    fn a_second_writer_is_refused_with_the_holders_pid_and_gets_in_once_it_is_gone() {
        let dir = scratch("two-writers");
        let first = RunLock::write(&dir).expect("first writer");
        let refused = RunLock::write(&dir).expect_err("second writer");
        let text = refused.to_string();
        assert!(
            text.contains(&format!("pid {}", std::process::id())),
            "{text}"
        );
        assert!(text.contains(&dir.display().to_string()), "{text}");
        assert!(
            RunLock::read(&dir).is_err(),
            "no reader while a writer writes"
        );
        drop(first);
        assert!(!dir.join(LOCK).exists(), "the writer removes its lock file");
        let _again = RunLock::write(&dir).expect("free again");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_lock_file_that_is_a_link_or_a_fifo_is_refused_and_what_it_points_to_kept() {
        let dir = scratch("linked");
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, b"precious").expect("victim");
        let run = dir.join("run");
        std::fs::create_dir(&run).expect("run");
        std::os::unix::fs::symlink("../victim.txt", run.join(LOCK)).expect("link");
        for e in [
            RunLock::write(&run).expect_err("a writer through a link"),
            RunLock::read(&run).expect_err("a reader through a link"),
        ] {
            let text = e.to_string();
            assert!(
                text.contains(".lock") && text.contains("symbolic link"),
                "{text}"
            );
        }
        assert_eq!(std::fs::read(&victim).expect("victim"), b"precious");
        assert!(writer(&run).is_none());
        std::fs::remove_file(run.join(LOCK)).expect("unlink");
        let made = std::process::Command::new("mkfifo")
            .arg(run.join(LOCK))
            .status()
            .expect("mkfifo");
        assert!(made.success());
        let e = RunLock::write(&run).expect_err("a FIFO");
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_writer_is_named_while_it_writes_and_not_after() {
        let dir = scratch("writer");
        assert_eq!(writer(&dir), None, "no lock file");
        let lock = RunLock::write(&dir).expect("writer");
        let holder = writer(&dir).expect("a writer");
        assert!(
            holder.contains(&format!("pid {}", std::process::id())),
            "{holder}"
        );
        // Looking did not take the lock from it.
        assert!(RunLock::read(&dir).is_err());
        drop(lock);
        let _reader = RunLock::read(&dir).expect("reader").expect("lock");
        assert_eq!(writer(&dir), None, "a reader is no writer");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn readers_share_and_keep_writers_out() {
        let dir = scratch("readers");
        let a = RunLock::read(&dir).expect("reader").expect("lock");
        let b = RunLock::read(&dir).expect("reader").expect("lock");
        let refused = RunLock::write(&dir).expect_err("writer while read");
        assert!(
            refused.to_string().contains("reading it whole"),
            "{refused}"
        );
        drop((a, b));
        assert!(
            !dir.join(LOCK).exists(),
            "the last reader removes the lock file"
        );
        let _w = RunLock::write(&dir).expect("writer after the readers");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
