//! Image output: OpenEXR (linear sRGB, f32) and an 8-bit sRGB PNG preview, written through
//! [`crate::io::output`] (checked before any work, a temporary file renamed into place), and
//! OpenEXR read back through [`crate::io::input`] (a regular file, its size checked from the
//! header before anything is allocated).

use crate::io::output::write_atomic;
use crate::spectrum::cie::srgb_encode;
use glam::Vec3;
use std::path::Path;

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

/// Write one layer of `channels` with the text attributes `text` (byte-identical for identical
/// input): the channel writer of shards and spectral images.
pub(crate) fn write_channels(
    path: &Path,
    (width, height): (u32, u32),
    channels: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
    text: &[(String, String)],
) -> Result<(), String> {
    use exr::prelude::*;
    let mut attrs = LayerAttributes::default();
    for (k, v) in text {
        attrs.other.insert(
            Text::from(k.as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    let size = (width as usize, height as usize);
    let channels = AnyChannels::sort(channels.into());
    let image = Image::from_layer(Layer::new(size, attrs, exr_encoding(), channels));
    write_atomic(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write EXR '{}': {e}", path.display()))
    })
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
pub const MAX_READ_PIXELS: usize = crate::io::limits::MAX_PIXELS as usize;

/// Read an RGB(A) OpenEXR as linear sRGB. It must be a regular file; its size is checked from
/// the header before anything is allocated.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::*;
    // the size is checked from the header before any pixel is allocated
    read_exr_header(path)?;
    let (reader, _) = crate::io::input::reader(path, crate::io::input::EXR)?;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| {
                (
                    res.width(),
                    res.height(),
                    vec![Vec3::ZERO; res.width() * res.height()],
                )
            },
            |(w, _, px): &mut (usize, usize, Vec<Vec3>),
             pos,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(|e| format!("cannot read EXR '{}': {e}", path.display()))?;
    let (w, h, px) = img.layer_data.channel_data.pixels;
    Ok((w as u32, h as u32, px))
}

/// The header of the OpenEXR `path` (a regular file), with its first layer's size checked: at
/// most [`MAX_READ_PIXELS`] pixels in every layer, none empty.
pub fn read_exr_header(
    path: &Path,
) -> Result<(exr::math::Vec2<usize>, exr::meta::MetaData), String> {
    let (reader, _) = crate::io::input::reader(path, crate::io::input::EXR)?;
    let meta = exr::meta::MetaData::read_from_buffered(reader, false)
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
    let first = meta
        .headers
        .first()
        .ok_or_else(|| format!("EXR '{}' has no layer", path.display()))?
        .layer_size;
    Ok((first, meta))
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
