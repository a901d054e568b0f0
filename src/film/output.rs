//! Image output: OpenEXR (linear sRGB, f32) and an 8-bit sRGB PNG preview. Both are written to
//! a temporary file in the target folder and renamed, so an interrupted run never leaves a
//! half-written image in place of an earlier one.

use crate::spectrum::cie::srgb_encode;
use glam::Vec3;
use std::path::{Path, PathBuf};

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
    let r = f(&tmp);
    if let Err(e) = r {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!(
            "cannot move the output into place at '{}': {e}",
            path.display()
        )
    })
}

/// Write linear sRGB as an RGB f32 OpenEXR.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<(), String> {
    write_atomic(path, |tmp| {
        exr::prelude::write_rgb_file(tmp, width as usize, height as usize, |x, y| {
            let c = rgb[y * width as usize + x];
            (c.x, c.y, c.z)
        })
        .map_err(|e| format!("cannot write EXR '{}': {e}", path.display()))
    })
}

/// Read an RGB(A) OpenEXR as linear sRGB.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::*;
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
