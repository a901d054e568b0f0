//! Image output: OpenEXR (linear sRGB, f32) and an 8-bit sRGB PNG preview. Both are written to
//! a temporary file in the target folder and renamed, so an interrupted run never leaves a
//! half-written image in place of an earlier one. The temporary files being written are listed
//! in a process-wide registry, so that a signal handler ([`remove_in_flight`]) can delete them
//! before the process exits.

use crate::spectrum::cie::srgb_encode;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files being written now (registered by [`write_atomic`] until renamed or removed).
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

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

fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write `bytes_writer` output to a temp file, then rename over `path`.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create folder '{}': {e}", dir.display()))?;
    }
    let tmp = temp_path(path);
    in_flight().push(tmp.clone());
    let r = f(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|e| {
            format!(
                "cannot move the output into place at '{}': {e}",
                path.display()
            )
        })
    });
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    let mut g = in_flight();
    if let Some(i) = g.iter().position(|p| p == &tmp) {
        g.swap_remove(i);
    }
    r
}

/// Check, before any work, that a file can be created in `path`'s folder (which must exist), and
/// that `path` is not a folder: create and remove a probe file there. The error says why not.
pub fn probe_writable(path: &Path) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!("'{}' is a folder, not a file", path.display()));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(format!("the folder '{}' does not exist", dir.display()));
    }
    let probe = dir.join(format!(".stokes-probe.{}.tmp", std::process::id()));
    in_flight().push(probe.clone());
    let r = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&probe)
        .map(drop)
        .map_err(|e| format!("cannot write in the folder '{}': {e}", dir.display()));
    let _ = std::fs::remove_file(&probe);
    in_flight().retain(|p| p != &probe);
    r
}

/// Whether `path` has the extension `ext` (ASCII case-insensitive, without the dot).
pub fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// The block layout of the EXRs we write: RLE-compressed 64×64 tiles (the exr crate's default)
/// written in increasing-y order. Blocks are still compressed in parallel, but the writer puts
/// them in the file in that fixed order, so identical images give identical bytes.
pub(crate) fn exr_encoding() -> exr::prelude::Encoding {
    use exr::prelude::*;
    Encoding {
        compression: Compression::RLE,
        blocks: Blocks::Tiles(Vec2(64, 64)),
        line_order: LineOrder::Increasing,
    }
}

/// Write linear sRGB as an RGB f32 OpenEXR (byte-identical for identical images).
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<(), String> {
    use exr::prelude::*;
    let (w, h) = (width as usize, height as usize);
    if rgb.len() != w * h {
        return Err(format!(
            "cannot write EXR '{}': {} pixels for a {width}×{height} image",
            path.display(),
            rgb.len()
        ));
    }
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let c = rgb[y * w + x];
        (c.x, c.y, c.z)
    });
    let image = Image::from_encoded_channels((w, h), exr_encoding(), channels);
    write_atomic(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write EXR '{}': {e}", path.display()))
    })
}

/// Most pixels of an EXR we read back (any image the renderer can make fits).
pub const MAX_READ_PIXELS: usize = 1 << 26;

/// Read an RGB(A) OpenEXR as linear sRGB. Its size is checked from the header before anything
/// is allocated.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| format!("cannot read EXR '{}': {e}", path.display()))?;
    for h in &meta.headers {
        let (w, ht) = (h.layer_size.width(), h.layer_size.height());
        if w == 0 || ht == 0 || w.saturating_mul(ht) > MAX_READ_PIXELS {
            return Err(format!(
                "EXR '{}': a layer of {w}×{ht} pixels (at most {MAX_READ_PIXELS} pixels, none empty)",
                path.display()
            ));
        }
    }
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| {
            (
                res.width(),
                res.height(),
                vec![Vec3::ZERO; res.width() * res.height()],
            )
        },
        |(w, _, px): &mut (usize, usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| format!("cannot read EXR '{}': {e}", path.display()))?;
    let (w, h, px) = img.layer_data.channel_data.pixels;
    Ok((w as u32, h as u32, px))
}

/// Write an 8-bit sRGB PNG preview; `exposure` is in stops.
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[Vec3],
    exposure: f32,
) -> Result<(), String> {
    if !exposure.is_finite() {
        return Err(format!(
            "cannot write PNG '{}': exposure {exposure} is not finite",
            path.display()
        ));
    }
    if rgb.len() != width as usize * height as usize {
        return Err(format!(
            "cannot write PNG '{}': {} pixels for a {width}×{height} image",
            path.display(),
            rgb.len()
        ));
    }
    let k = 2f32.powf(exposure);
    let mut buf = Vec::with_capacity(rgb.len() * 3);
    for c in rgb {
        for v in [c.x, c.y, c.z] {
            let v = if v.is_finite() { v * k } else { 0.0 };
            buf.push((srgb_encode(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8);
        }
    }
    write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &buf,
            width,
            height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("cannot write PNG '{}': {e}", path.display()))
    })
}
