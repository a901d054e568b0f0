//! Opening what stokes reads. Every input is opened here: without blocking (a FIFO with no
//! writer would otherwise hold `open()` for ever), then checked with `fstat` to be a regular file
//! (not a FIFO, a device such as `/dev/zero`, a socket or a folder) of at most its kind's size
//! cap, and read through a `take` of that cap, so nothing is allocated from what is read before
//! it has been checked. The caps are far above any real file of the kind.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// A kind of input file: its name in messages and its size cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    /// What the file is, for messages ("scene", "BFC matrix", …).
    pub what: &'static str,
    /// Most bytes a file of this kind may hold.
    pub max_bytes: u64,
}

const MIB: u64 = 1 << 20;

/// A scene (JSON).
pub const SCENE: Kind = Kind::new("scene", 64 * MIB);
/// An experiment config (JSON).
pub const CONFIG: Kind = Kind::new("experiment config", 16 * MIB);
/// A tabulated spectrum or illuminant (`wavelength, value` CSV).
pub const SPECTRUM_CSV: Kind = Kind::new("spectrum CSV", 16 * MIB);
/// A measured reradiation matrix (Labsphere BFC-450).
pub const BFC: Kind = Kind::new("BFC matrix", 16 * MIB);
/// A fitted Gaussian-mixture model (JSON).
pub const GMM_MODEL: Kind = Kind::new("Gaussian-mixture model", 16 * MIB);
/// A Wavefront OBJ mesh (read as a stream, lines capped at [`MAX_LINE_BYTES`]).
pub const OBJ: Kind = Kind::new("OBJ mesh", 2048 * MIB);
/// A material library of an OBJ mesh.
pub const MTL: Kind = Kind::new("OBJ material library", 16 * MIB);
/// A Mitsuba `.vol` density grid (its header is checked against its length too).
pub const VOL: Kind = Kind::new(".vol density grid", 1024 * MIB);
/// An OpenEXR image (its header is checked before its pixels are read).
pub const EXR: Kind = Kind::new("OpenEXR image", 16384 * MIB);
/// A JSON record of a run (`run.json`, `plan.json`, `summary.json`, `done.json`, …).
pub const RUN_RECORD: Kind = Kind::new("run record", 64 * MIB);
/// A run's `metrics.csv`, or a planned run's `jobs.jsonl`.
pub const RUN_TABLE: Kind = Kind::new("run table", 256 * MIB);
/// A `latest` file of an experiment folder (the name of a run folder).
pub const LATEST: Kind = Kind::new("`latest` pointer", 4096);

/// Longest line a streamed text input (an OBJ mesh) may hold.
pub const MAX_LINE_BYTES: usize = 1 << 20;

impl Kind {
    pub const fn new(what: &'static str, max_bytes: u64) -> Kind {
        Kind { what, max_bytes }
    }
}

/// What a file type is, for messages ("a FIFO (named pipe)", "a character device", …).
pub fn type_name(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        "a folder"
    } else if ft.is_symlink() {
        "a symbolic link"
    } else if ft.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Open `path` as an input of `kind`: it must be a regular file (links are followed) of at most
/// `kind.max_bytes`. Returns the file and its length. The error names the file and says what it
/// is instead.
pub fn open(path: &Path, kind: Kind) -> Result<(File, u64), String> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A FIFO without a writer would block `open` for ever; a regular file ignores the flag.
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o
        .open(path)
        .map_err(|e| format!("cannot open '{}': {e}", path.display()))?;
    let m = f
        .metadata()
        .map_err(|e| format!("cannot read the type of '{}': {e}", path.display()))?;
    if !m.file_type().is_file() {
        return Err(format!(
            "'{}' is {}, not a regular file (the {} must be a regular file)",
            path.display(),
            type_name(&m.file_type()),
            kind.what
        ));
    }
    if m.len() > kind.max_bytes {
        return Err(too_big(path, kind, m.len()));
    }
    Ok((f, m.len()))
}

fn too_big(path: &Path, kind: Kind, len: u64) -> String {
    format!(
        "'{}' holds {len} bytes, more than the {} bytes allowed for the {}",
        path.display(),
        kind.max_bytes,
        kind.what
    )
}

/// The bytes of the input `path` of `kind` ([`open`]'s checks; a file that grows past the cap
/// while it is read is refused too).
pub fn read_bytes(path: &Path, kind: Kind) -> Result<Vec<u8>, String> {
    let (f, len) = open(path, kind)?;
    let mut buf = Vec::with_capacity(len as usize);
    f.take(kind.max_bytes + 1)
        .read_to_end(&mut buf)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    if buf.len() as u64 > kind.max_bytes {
        return Err(too_big(path, kind, buf.len() as u64));
    }
    Ok(buf)
}

/// The text of the input `path` of `kind`, which must be UTF-8; a leading UTF-8 byte-order mark
/// (some editors write one) is dropped.
pub fn read_text(path: &Path, kind: Kind) -> Result<String, String> {
    let bytes = read_bytes(path, kind)?;
    let mut s = String::from_utf8(bytes).map_err(|e| {
        format!(
            "'{}' is not UTF-8 text (byte {} is not valid UTF-8; the {} is a text file)",
            path.display(),
            e.utf8_error().valid_up_to(),
            kind.what
        )
    })?;
    if s.starts_with('\u{feff}') {
        s.drain(..'\u{feff}'.len_utf8());
    }
    Ok(s)
}

/// A buffered reader of the input `path` of `kind`, which stops at the cap.
pub fn reader(path: &Path, kind: Kind) -> Result<(BufReader<std::io::Take<File>>, u64), String> {
    let (f, len) = open(path, kind)?;
    Ok((BufReader::new(f.take(kind.max_bytes)), len))
}

/// A reader that fails on a line longer than its cap, so that a line-by-line parser (tobj)
/// never grows one line without bound.
pub struct LineCapped<R> {
    inner: R,
    /// Bytes since the last newline.
    run: usize,
    cap: usize,
    /// A line past the cap was seen: every further read fails.
    over: bool,
}

impl<R: BufRead> LineCapped<R> {
    /// Whether a line past the cap was seen.
    pub fn overlong(&self) -> bool {
        self.over
    }

    pub fn new(inner: R, cap: usize) -> Self {
        LineCapped {
            inner,
            run: 0,
            cap,
            over: false,
        }
    }
}

impl<R: BufRead> Read for LineCapped<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let n = {
            let b = self.fill_buf()?;
            let n = b.len().min(out.len());
            out[..n].copy_from_slice(&b[..n]);
            n
        };
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for LineCapped<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.over {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("a line longer than {} bytes", self.cap),
            ));
        }
        self.inner.fill_buf()
    }

    fn consume(&mut self, n: usize) {
        // The bytes being consumed are still in the inner buffer: no read happens here.
        if let Ok(b) = self.inner.fill_buf() {
            let mut lines = b[..n.min(b.len())].split(|&c| c == b'\n');
            let mut run = self.run + lines.next().map_or(0, <[u8]>::len);
            self.over |= run > self.cap;
            for l in lines {
                run = l.len();
                self.over |= run > self.cap;
            }
            self.run = run;
        }
        self.inner.consume(n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("stokes-io-input-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d.join(name)
    }

    #[test]
    fn regular_files_within_the_cap_are_read_and_the_bom_dropped() {
        let p = tmp("a.json");
        std::fs::write(&p, "\u{feff}{}").unwrap();
        assert_eq!(read_text(&p, SCENE).unwrap(), "{}");
        let e = read_text(&p, Kind::new("thing", 2)).unwrap_err();
        assert!(
            e.contains("more than the 2 bytes allowed for the thing"),
            "{e}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn devices_folders_and_fifos_are_refused_at_once() {
        let e = read_text(Path::new("/dev/zero"), SCENE).unwrap_err();
        assert!(
            e.contains("is a character device, not a regular file"),
            "{e}"
        );
        let e = read_text(&std::env::temp_dir(), SCENE).unwrap_err();
        assert!(e.contains("is a folder"), "{e}");
        let fifo = tmp("fifo");
        let _ = std::fs::remove_file(&fifo);
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_text(&fifo, CONFIG).unwrap_err();
        assert!(e.contains("is a FIFO (named pipe)"), "{e}");
    }

    #[test]
    fn a_line_past_the_cap_is_an_error() {
        let text = format!("v 1 2 3\n{}\n", "x".repeat(100));
        let mut r = LineCapped::new(std::io::Cursor::new(text.as_bytes()), 50);
        let mut out = String::new();
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        assert_eq!(line, "v 1 2 3\n");
        assert!(r.read_to_string(&mut out).is_err());
        let mut ok = LineCapped::new(std::io::Cursor::new(b"ab\ncd\n".as_slice()), 3);
        let mut s = String::new();
        ok.read_to_string(&mut s).unwrap();
        assert_eq!(s, "ab\ncd\n");
    }
}
