//! Writing what stokes makes. An output is checked before any work ([`check_output`]): it is a
//! regular file or does not exist yet, its name is legal on its file system, and its folder
//! exists and takes a new file. It is then written to a temporary file beside it and renamed
//! into place ([`write_atomic`]), so an interrupted run never leaves a half-written file in place
//! of an earlier one, and the rename never replaces anything but a regular file: a device node,
//! a FIFO, a folder or a link at the output's path is refused, also when it appears after the
//! check. The temporary files being written are listed in a process-wide registry, so that a
//! signal handler ([`remove_in_flight`]) can delete them before the process exits.

use super::input::type_name;
use super::text::show_path;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Temporary files being written now (registered by [`write_atomic`] until renamed or removed).
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Makes every temporary name of this process unique.
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

fn in_flight() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    IN_FLIGHT.lock().unwrap_or_else(|p| p.into_inner())
}

/// The temporary files being written now.
pub fn in_flight_paths() -> Vec<PathBuf> {
    in_flight().clone()
}

/// Delete every temporary file being written now (for a signal handler that is about to exit).
/// The registry stays locked afterwards until the process exits, so no new one is started.
pub fn remove_in_flight() {
    let mut g = in_flight();
    for p in g.drain(..) {
        let _ = std::fs::remove_file(&p);
    }
    std::mem::forget(g);
}

fn register(p: &Path) {
    in_flight().push(p.to_path_buf());
}

fn unregister(p: &Path) {
    let mut g = in_flight();
    if let Some(i) = g.iter().position(|q| q == p) {
        g.swap_remove(i);
    }
}

/// The temporary file an output is written to: `.NAME.PID.N.tmp` beside it, NAME cut to 64
/// bytes so that the temporary name is legal wherever the output's is.
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let mut cut = name.len().min(64);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{}.{}.{n}.tmp", &name[..cut], std::process::id()))
}

/// The folder of `path` ("." for a bare name).
fn folder(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Whether an error of the file system says that nothing is at the path: it does not exist, or
/// one of its folders is a file.
fn absent(e: &std::io::Error) -> bool {
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ENOTDIR) {
        return true;
    }
    e.kind() == std::io::ErrorKind::NotFound
}

/// An error unless what is at `path` (not following a link) is a regular file or nothing.
pub fn refuse_non_regular(path: &Path) -> Result<(), String> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => Err(format!(
            "'{}' is {}, not a regular file: stokes writes its outputs only to regular files and \
             never replaces a device, a FIFO, a folder or a link",
            show_path(path),
            type_name(&m.file_type())
        )),
        Err(e) if absent(&e) => Ok(()),
        Err(e) => Err(name_error(path, &e)),
    }
}

/// The message of an error from the file system about `path`, with a plain word for a name
/// that is too long.
fn name_error(path: &Path, e: &std::io::Error) -> String {
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ENAMETOOLONG) {
        return format!(
            "'{}': the path ({} bytes) or one of its names is too long for the file system",
            show_path(path),
            path.as_os_str().len()
        );
    }
    format!("'{}': {e}", show_path(path))
}

/// Check, before any work, that `path` can take an output, and return the path to write: the
/// path itself, or the target of a link (which must exist and be a regular file). It must be a
/// regular file or not exist, its folder must exist and take a new file, and its name must be
/// legal there (a file of that name is created and removed when there is none yet). The error
/// says which of these fails.
pub fn check_output(path: &Path) -> Result<PathBuf, String> {
    if path.file_name().is_none() {
        return Err(format!("'{}' names no file", show_path(path)));
    }
    let target = match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            let t = std::fs::canonicalize(path).map_err(|e| {
                format!(
                    "'{}' is a symbolic link whose target cannot be used: {e}",
                    show_path(path)
                )
            })?;
            refuse_non_regular(&t)?;
            t
        }
        Ok(_) => {
            refuse_non_regular(path)?;
            path.to_path_buf()
        }
        Err(e) if absent(&e) => path.to_path_buf(),
        Err(e) => return Err(name_error(path, &e)),
    };
    let dir = folder(&target);
    if !dir.is_dir() {
        return Err(format!("the folder '{}' does not exist", show_path(dir)));
    }
    if target.exists() {
        // The rename needs a new file in the folder.
        let probe = temp_path(&target);
        create_and_remove(&probe)
            .map_err(|e| format!("cannot write in the folder '{}': {e}", show_path(dir)))?;
        return Ok(target);
    }
    create_and_remove(&target).map_err(|e| {
        #[cfg(unix)]
        if e.raw_os_error() == Some(libc::ENAMETOOLONG) {
            return name_error(&target, &e);
        }
        format!("cannot create '{}': {e}", show_path(&target))
    })?;
    Ok(target)
}

/// Create `p` (which must not exist) and remove it again.
fn create_and_remove(p: &Path) -> std::io::Result<()> {
    register(p);
    let r = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(p)
        .map(drop);
    if r.is_ok() {
        let _ = std::fs::remove_file(p);
    }
    unregister(p);
    r
}

/// Check, before any work, that files can be created in the folder `dir`, which must exist.
pub fn check_folder(dir: &Path) -> Result<(), String> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(m) => {
            return Err(format!(
                "'{}' is {}, not a folder",
                show_path(dir),
                type_name(&m.file_type())
            ));
        }
        Err(e) => return Err(format!("the folder '{}': {e}", show_path(dir))),
    }
    let probe = temp_path(&dir.join("probe"));
    create_and_remove(&probe)
        .map_err(|e| format!("cannot write in the folder '{}': {e}", show_path(dir)))
}

/// Write an output through `f`, which writes the temporary file it is given; then rename that
/// over `path`. Missing folders are created. Refused when `path` is not a regular file (checked
/// before and again just before the rename); on any error the temporary file is removed.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    let dir = folder(path);
    if !dir.is_dir() {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create folder '{}': {e}", show_path(dir)))?;
    }
    refuse_non_regular(path)?;
    let tmp = temp_path(path);
    register(&tmp);
    let r = f(&tmp)
        .and_then(|()| refuse_non_regular(path))
        .and_then(|()| {
            std::fs::rename(&tmp, path).map_err(|e| {
                format!(
                    "cannot move the output into place at '{}': {e}",
                    show_path(path)
                )
            })
        });
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    unregister(&tmp);
    r
}

/// Write `bytes` to `path` atomically ([`write_atomic`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_atomic(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| format!("cannot write '{}': {e}", show_path(path)))
    })
}

/// Whether `path` has the extension `ext` (ASCII case-insensitive, without the dot).
pub fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// An output path with its (existing) folder made canonical, so that `./P` and `P` compare
/// equal.
pub fn canonical_output(p: &Path) -> PathBuf {
    let dir = folder(p);
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    match p.file_name() {
        Some(n) => dir.join(n),
        None => dir,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("stokes-io-out-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn outputs_are_regular_files_with_legal_names() {
        let d = dir("legal");
        let p = d.join("a.exr");
        assert_eq!(check_output(&p).unwrap(), p);
        assert!(!p.exists(), "the check leaves no file behind");
        let long = d.join(format!("{}.exr", "x".repeat(300)));
        let e = check_output(&long).unwrap_err();
        assert!(e.contains("too long"), "{e}");
        let e = check_output(&d).unwrap_err();
        assert!(e.contains("is a folder"), "{e}");
        #[cfg(unix)]
        {
            let e = check_output(Path::new("/dev/full")).unwrap_err();
            assert!(e.contains("character device"), "{e}");
            let link = d.join("l.exr");
            std::os::unix::fs::symlink("/dev/null", &link).unwrap();
            let e = check_output(&link).unwrap_err();
            assert!(e.contains("/dev/null"), "{e}");
            let e = write_bytes(&link, b"x").unwrap_err();
            assert!(e.contains("symbolic link"), "{e}");
            assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
            // A link to a regular file is written through.
            std::fs::write(d.join("t.exr"), "old").unwrap();
            let l2 = d.join("l2.exr");
            std::os::unix::fs::symlink(d.join("t.exr"), &l2).unwrap();
            assert_eq!(
                check_output(&l2).unwrap(),
                d.join("t.exr").canonicalize().unwrap()
            );
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn an_atomic_write_replaces_only_a_regular_file() {
        let d = dir("atomic");
        let p = d.join("x.json");
        write_bytes(&p, b"1").unwrap();
        write_bytes(&p, b"2").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"2");
        std::fs::create_dir(d.join("sub")).unwrap();
        assert!(write_bytes(&d.join("sub"), b"3").is_err());
        assert!(d.join("sub").is_dir());
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
        assert_eq!(left.len(), 2, "no temporary file is left");
        let _ = std::fs::remove_dir_all(&d);
    }
}
