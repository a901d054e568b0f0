//! Run folders and results roots as untrusted input. A run folder is copied between machines
//! and edited by hand, so before stokes writes into one it checks the whole folder: every entry
//! below it must be a folder or a regular file. A symbolic link would take a write out of the
//! folder (`jobs/` pointing elsewhere), and a FIFO or a device would hang or be replaced.
//! The parts of a results root that a run writes (`<name>/latest`, `references/`) are checked the
//! same way, one path at a time.

use super::input::type_name;
use super::text::show_path;
use std::path::{Component, Path};

/// Most entries a run folder may hold (a run has a few hundred to a few thousand).
const MAX_ENTRIES: usize = 1 << 20;
/// Deepest nesting below a run folder (a sweep's runs are three levels deep).
const MAX_DEPTH: usize = 32;

/// Whether `p` is a relative path that stays inside its base: only normal components (and
/// `.`), at least one, none too long for a file name.
pub fn safe_relative(p: &str) -> bool {
    !p.is_empty()
        && !p.contains('\0')
        && Path::new(p).components().all(|c| match c {
            Component::Normal(n) => n.len() <= 255,
            Component::CurDir => true,
            _ => false,
        })
        && Path::new(p)
            .components()
            .any(|c| matches!(c, Component::Normal(_)))
}

/// Whether `s` is one plain file or folder name: not empty, not `.` or `..`, no `/` or NUL, at
/// most 255 bytes.
pub fn plain_name(s: &str) -> bool {
    !s.is_empty() && s != "." && s != ".." && !s.contains(['/', '\0']) && s.len() <= 255
}

/// Check the run folder `dir` before anything is written into it: it is a folder (not a link to
/// one), and every entry below it is a folder or a regular file: no symbolic link, FIFO, device
/// or socket. The error names the entry and the run folder.
pub fn check_run_folder(dir: &Path) -> Result<(), String> {
    let m = std::fs::symlink_metadata(dir)
        .map_err(|e| format!("run folder '{}': {e}", show_path(dir)))?;
    if !m.is_dir() {
        return Err(format!(
            "run folder '{}' is {}, not a folder",
            show_path(dir),
            type_name(&m.file_type())
        ));
    }
    let mut seen = 0usize;
    walk(dir, dir, 0, &mut seen)
}

fn walk(run: &Path, dir: &Path, depth: usize, seen: &mut usize) -> Result<(), String> {
    let rd =
        std::fs::read_dir(dir).map_err(|e| format!("cannot list '{}': {e}", show_path(dir)))?;
    for e in rd {
        let e = e.map_err(|e| format!("cannot list '{}': {e}", show_path(dir)))?;
        *seen += 1;
        if *seen > MAX_ENTRIES {
            return Err(format!(
                "run folder '{}' holds more than {MAX_ENTRIES} files and folders",
                show_path(run)
            ));
        }
        let p = e.path();
        let ft = e
            .file_type()
            .map_err(|err| format!("cannot read the type of '{}': {err}", show_path(&p)))?;
        if ft.is_dir() {
            if depth + 1 > MAX_DEPTH {
                return Err(format!(
                    "'{}' is nested more than {MAX_DEPTH} folders deep in the run folder '{}'",
                    show_path(&p),
                    show_path(run)
                ));
            }
            walk(run, &p, depth + 1, seen)?;
        } else if !ft.is_file() {
            return Err(refusal(&p, &ft, run));
        }
    }
    Ok(())
}

fn refusal(p: &Path, ft: &std::fs::FileType, base: &Path) -> String {
    let why = if ft.is_symlink() {
        "stokes never follows a link inside a run folder or results root when it writes there \
         (replace the link by what it points to)"
    } else {
        "a run folder or results root holds only folders and regular files"
    };
    format!(
        "'{}' is {} inside '{}': {why}",
        show_path(p),
        type_name(ft),
        show_path(base)
    )
}

/// Check the path `rel` below `root` before writing there: each part of it that exists is a
/// folder (the last may be a regular file), none a link. `root` itself may be a link.
pub fn check_below(root: &Path, rel: &Path) -> Result<(), String> {
    let parts: Vec<_> = rel.components().collect();
    let mut p = root.to_path_buf();
    for (i, c) in parts.iter().enumerate() {
        match c {
            Component::Normal(n) => p.push(n),
            Component::CurDir => continue,
            _ => {
                return Err(format!("'{}' leaves '{}'", show_path(rel), show_path(root)));
            }
        }
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.is_dir() => {}
            Ok(m) if m.is_file() && i + 1 == parts.len() => {}
            Ok(m) => return Err(refusal(&p, &m.file_type(), root)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            Err(e) => return Err(format!("'{}': {e}", show_path(&p))),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_relative_paths() {
        assert!(safe_relative("images/a.exr") && safe_relative("./x"));
        for bad in ["", ".", "/abs", "../x", "a/../../b", "a\0b"] {
            assert!(!safe_relative(bad), "{bad:?}");
        }
        assert!(plain_name("20261201-120000") && plain_name("walls.v2"));
        for bad in ["", ".", "..", "a/b", "../../x"] {
            assert!(!plain_name(bad), "{bad:?}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn links_and_special_files_in_a_run_folder_are_refused() {
        let d = std::env::temp_dir().join(format!("stokes-io-tree-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("run/jobs/00000")).unwrap();
        std::fs::write(d.join("run/jobs/00000/done.json"), "{}").unwrap();
        check_run_folder(&d.join("run")).unwrap();
        std::os::unix::fs::symlink(&d, d.join("run/jobs/00001")).unwrap();
        let e = check_run_folder(&d.join("run")).unwrap_err();
        assert!(e.contains("00001' is a symbolic link"), "{e}");
        std::fs::remove_file(d.join("run/jobs/00001")).unwrap();
        assert!(check_below(&d, Path::new("run/jobs/00000/done.json")).is_ok());
        assert!(check_below(&d, Path::new("run/none/x")).is_ok());
        std::os::unix::fs::symlink("/tmp", d.join("references")).unwrap();
        assert!(check_below(&d, Path::new("references/a.exr")).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
