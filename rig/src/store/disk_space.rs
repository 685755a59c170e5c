//! Room on the disk: how many bytes the filesystem holding a path can still take, so a job that
//! writes gigabytes says before it starts that they will not fit, instead of failing hours in.

use std::ffi::CString;
use std::io;
use std::os::unix::ffi::OsStrExt;
use std::path::Path;

/// Bytes an unprivileged process may still write on the filesystem that holds `path` (or, when
/// `path` does not exist yet, its nearest existing ancestor).
pub fn available_bytes(path: &Path) -> io::Result<u64> {
    let existing = path
        .ancestors()
        .find(|a| !a.as_os_str().is_empty() && a.exists())
        .unwrap_or(Path::new("."));
    let c = CString::new(existing.as_os_str().as_bytes())
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    // SAFETY: statvfs writes into the zeroed struct it is given; the path is a valid C string.
    let mut s: libc::statvfs = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::statvfs(c.as_ptr(), &mut s) };
    if rc != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok((s.f_bavail as u64).saturating_mul(s.f_frsize as u64))
}

/// `bytes` for a person: "3.3 GB", "820 MB".
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1e12 {
        format!("{:.1} TB", b / 1e12)
    } else if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else {
        format!("{:.0} MB", (b / 1e6).ceil())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_temporary_directory_has_room_and_a_path_to_be_made_is_measured_at_its_parent() {
        let tmp = std::env::temp_dir();
        let here = available_bytes(&tmp).expect("statvfs");
        assert!(here > 0);
        let later = available_bytes(&tmp.join("not/made/yet")).expect("statvfs of the parent");
        // The same filesystem; other tests may write meanwhile.
        assert!(later.abs_diff(here) < 1 << 30, "{here} vs {later}");
        assert_eq!(human(3_300_000_000), "3.3 GB");
        assert_eq!(human(819_500_000), "820 MB");
    }
}
