//! Films as sample-range shards: an EXR that says which samples it holds and what it was
//! rendered from, and carries the film's f64 sums exactly, so shards of one render merge into
//! the image of the whole range.
//!
//! Sampling is deterministic per (seed, pixel, sample index), so samples `FROM..TO` of a render
//! are the same whichever process renders them. A shard EXR holds:
//! - the image of its own samples as `R`, `G`, `B` (f32, linear sRGB), for any viewer;
//! - one header attribute `stokes.film`, a JSON object with `samples` (`"FROM..TO"`), `spp`,
//!   `seed`, `integrator`, `options`, `scene` and `sceneHash` (one attribute because the EXR
//!   writer stores attributes in hash order: several would make identical renders differ in
//!   bytes);
//! - the film's camera and splat sums in XYZ as f64 bit patterns, each split into two `u32`
//!   channels (`stokes.sum.X.hi`, `stokes.sum.X.lo`, …, `stokes.splat.Z.lo`).
//!
//! [`merge`] adds the sums in sample order and writes a shard of the union, which refuses
//! shards of different scenes, seeds, integrators, options or sizes, and ranges that overlap or
//! leave a gap.

use super::Film;
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What a film was rendered from and which samples it holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShardInfo {
    /// The scene file, for messages (not compared).
    pub scene: String,
    /// Hash of the scene file's text.
    pub scene_hash: String,
    pub integrator: String,
    /// The integrator options as JSON.
    pub options: String,
    pub seed: u64,
    /// First sample index.
    pub from: u32,
    /// One past the last sample index.
    pub to: u32,
}

/// A shard read back: where it came from, its size, and its f64 sums (camera, splat) in XYZ.
pub struct Shard {
    pub path: PathBuf,
    pub info: ShardInfo,
    pub width: u32,
    pub height: u32,
    pub sum: Vec<[f64; 3]>,
    pub splat: Vec<[f64; 3]>,
}

const SUMS: [&str; 2] = ["sum", "splat"];
const XYZ: [&str; 3] = ["X", "Y", "Z"];

/// Parse a sample range `FROM..TO` (TO exclusive, FROM < TO).
pub fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("'{s}' is not a sample range FROM..TO (e.g. 0..16)"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{s}': '{t}' is not a sample index (0–{})", u32::MAX))
    };
    let (from, to) = (num(a)?, num(b)?);
    if from >= to {
        return Err(format!(
            "'{s}': the range is empty (FROM must be below TO, which is excluded)"
        ));
    }
    Ok((from, to))
}

/// Write `film` (which must hold exactly the samples `info.from..info.to`) as a shard EXR.
pub fn write_shard(path: &Path, film: &Film, info: &ShardInfo) -> Result<(), String> {
    write_film(path, film, info, true)
}

/// Write `film` as an EXR with the shard attributes, and with its exact sums when `sums`
/// (without them the file says what it holds but cannot be merged).
pub fn write_film(path: &Path, film: &Film, info: &ShardInfo, sums: bool) -> Result<(), String> {
    if film.spp != info.to - info.from {
        return Err(format!(
            "cannot write shard '{}': the film holds {} samples, the range {}..{} has {}",
            path.display(),
            film.spp,
            info.from,
            info.to,
            info.to - info.from
        ));
    }
    let rgb = film.rgb();
    write_sums(
        path,
        film.width,
        film.height,
        &rgb,
        sums.then_some([&film.sum[..], &film.splat[..]]),
        info,
    )
}

/// Write the image `rgb` with the sums and attributes of a shard.
fn write_sums(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[Vec3],
    sums: Option<[&[[f64; 3]]; 2]>,
    info: &ShardInfo,
) -> Result<(), String> {
    use exr::prelude::*;
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v: Vec<f32> = rgb.iter().map(|p| p.to_array()[c]).collect();
        list.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    for (k, buf) in SUMS.iter().zip(sums.into_iter().flatten()) {
        for (c, axis) in XYZ.iter().enumerate() {
            let bits: Vec<u64> = buf.iter().map(|p| p[c].to_bits()).collect();
            let hi = bits.iter().map(|b| (b >> 32) as u32).collect();
            let lo = bits.iter().map(|b| *b as u32).collect();
            list.push(AnyChannel::new(
                format!("stokes.{k}.{axis}.hi").as_str(),
                FlatSamples::U32(hi),
            ));
            list.push(AnyChannel::new(
                format!("stokes.{k}.{axis}.lo").as_str(),
                FlatSamples::U32(lo),
            ));
        }
    }
    super::output::write_channels(path, (width, height), list.into_vec(), &attributes(info))
}

/// The name of the header attribute that describes a film.
pub const ATTRIBUTE: &str = "stokes.film";

/// The header attributes of a shard: [`ATTRIBUTE`] as JSON.
pub fn attributes(i: &ShardInfo) -> Vec<(String, String)> {
    let options: serde_json::Value =
        serde_json::from_str(&i.options).unwrap_or(serde_json::Value::String(i.options.clone()));
    let v = serde_json::json!({
        "samples": format!("{}..{}", i.from, i.to),
        "spp": i.to - i.from,
        "seed": i.seed,
        "integrator": i.integrator,
        "options": options,
        "scene": i.scene,
        "sceneHash": i.scene_hash,
    });
    // An EXR text attribute holds Latin-1 only: non-ASCII (a scene path such as `☃.json`) is
    // escaped as JSON `\uXXXX`, which reads back as the same string.
    vec![(
        ATTRIBUTE.into(),
        crate::io::text::json_ascii(&v.to_string()),
    )]
}

/// Read a shard EXR back, checking its attributes and sums as untrusted input.
pub fn read_shard(path: &Path) -> Result<Shard, String> {
    use exr::prelude::*;
    let (size, meta) = crate::film::output::read_exr_header(path)?;
    let h = &meta.headers[0];
    let (w, ht) = (size.width(), size.height());
    let info = info_from(path, &text_attributes(h))?;
    let (reader, _) = crate::io::input::reader(path, crate::io::input::EXR)?;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(|e| format!("cannot read EXR '{}': {e}", path.display()))?;
    let channels = &img.layer_data.channel_data.list;
    let n = w * ht;
    let mut sums = [vec![[0.0f64; 3]; n], vec![[0.0f64; 3]; n]];
    for (k, buf) in SUMS.iter().zip(sums.iter_mut()) {
        for (c, axis) in XYZ.iter().enumerate() {
            let get = |part: &str| {
                let name = format!("stokes.{k}.{axis}.{part}");
                channels
                    .iter()
                    .find(|ch| ch.name.to_string() == name)
                    .and_then(|ch| match &ch.sample_data {
                        FlatSamples::U32(v) if v.len() == n => Some(v),
                        _ => None,
                    })
                    .ok_or_else(|| {
                        format!(
                            "'{}': channel `{name}` (u32, one per pixel) is missing: the file holds no exact sample sums; render shards with `stokes render --samples FROM..TO`",
                            path.display()
                        )
                    })
            };
            let (hi, lo) = (get("hi")?, get("lo")?);
            for (i, p) in buf.iter_mut().enumerate() {
                let v = f64::from_bits(((hi[i] as u64) << 32) | lo[i] as u64);
                if !v.is_finite() {
                    return Err(format!(
                        "'{}': channel `stokes.{k}.{axis}`: pixel ({}, {}) is not finite",
                        path.display(),
                        i % w,
                        i / w
                    ));
                }
                p[c] = v;
            }
        }
    }
    let [sum, splat] = sums;
    Ok(Shard {
        path: path.to_path_buf(),
        info,
        width: w as u32,
        height: ht as u32,
        sum,
        splat,
    })
}

/// The text attributes of an EXR layer header, by name.
pub fn text_attributes(h: &exr::meta::header::Header) -> HashMap<String, String> {
    use exr::prelude::AttributeValue;
    h.own_attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect()
}

/// The shard attributes from an EXR header's text attributes.
fn info_from(path: &Path, t: &HashMap<String, String>) -> Result<ShardInfo, String> {
    let bad = |m: String| format!("'{}': header attribute `{ATTRIBUTE}`: {m}", path.display());
    let text = t.get(ATTRIBUTE).ok_or_else(|| {
        format!(
            "'{}': header attribute `{ATTRIBUTE}` is missing: not a film written by `stokes render` (render shards with `stokes render --samples FROM..TO`)",
            path.display()
        )
    })?;
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let field = |k: &str| {
        v.get(k)
            .ok_or_else(|| bad(format!("field `{k}` is missing")))
    };
    let string = |k: &str| {
        field(k)?
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| bad(format!("field `{k}` is not a string")))
    };
    let uint = |k: &str| {
        field(k)?
            .as_u64()
            .ok_or_else(|| bad(format!("field `{k}` is not an unsigned integer")))
    };
    let samples = string("samples")?;
    let (from, to) = parse_range(&samples).map_err(|e| bad(format!("field `samples`: {e}")))?;
    let spp = uint("spp")?;
    if spp != (to - from) as u64 {
        return Err(bad(format!(
            "field `spp` is {spp}, but `samples` {samples} holds {} samples",
            to - from
        )));
    }
    Ok(ShardInfo {
        scene: string("scene")?,
        scene_hash: string("sceneHash")?,
        integrator: string("integrator")?,
        // Compared as text: the canonical (sorted-key) form.
        options: field("options")?.to_string(),
        seed: uint("seed")?,
        from,
        to,
    })
}

/// Merge shards of one render into a shard of the union of their ranges: the sums are added in
/// sample order. Refuses shards that differ in scene, seed, integrator, options or size, and
/// ranges that overlap or leave a gap. Returns the merged shard (path empty).
pub fn merge(mut shards: Vec<Shard>) -> Result<Shard, String> {
    if shards.is_empty() {
        return Err("no shards to merge".into());
    }
    shards.sort_by_key(|s| s.info.from);
    let first = &shards[0];
    for s in &shards[1..] {
        let differs = |what: &str, a: &str, b: &str| {
            format!(
                "'{}' and '{}' are not shards of one render: {what} ({a} / {b})",
                first.path.display(),
                s.path.display()
            )
        };
        let (a, b) = (&first.info, &s.info);
        if a.scene_hash != b.scene_hash {
            return Err(differs(
                "the scene differs",
                &format!("{} {}", a.scene, a.scene_hash),
                &format!("{} {}", b.scene, b.scene_hash),
            ));
        }
        if a.seed != b.seed {
            return Err(differs(
                "the seed differs",
                &a.seed.to_string(),
                &b.seed.to_string(),
            ));
        }
        if a.integrator != b.integrator {
            return Err(differs(
                "the integrator differs",
                &a.integrator,
                &b.integrator,
            ));
        }
        if a.options != b.options {
            return Err(differs(
                "the integrator options differ",
                &a.options,
                &b.options,
            ));
        }
        if (first.width, first.height) != (s.width, s.height) {
            return Err(differs(
                "the image size differs",
                &format!("{}×{}", first.width, first.height),
                &format!("{}×{}", s.width, s.height),
            ));
        }
    }
    for p in shards.windows(2) {
        let (a, b) = (&p[0], &p[1]);
        if b.info.from < a.info.to {
            return Err(format!(
                "'{}' (samples {}..{}) and '{}' (samples {}..{}) overlap: each sample must be in one shard",
                a.path.display(),
                a.info.from,
                a.info.to,
                b.path.display(),
                b.info.from,
                b.info.to
            ));
        }
        if b.info.from > a.info.to {
            return Err(format!(
                "samples {}..{} are in no shard: '{}' ends at {} and '{}' starts at {}",
                a.info.to,
                b.info.from,
                a.path.display(),
                a.info.to,
                b.path.display(),
                b.info.from
            ));
        }
    }
    let mut it = shards.into_iter();
    let mut out = it.next().unwrap();
    for s in it {
        add(&mut out.sum, &s.sum);
        add(&mut out.splat, &s.splat);
        out.info.to = s.info.to;
    }
    out.path = PathBuf::new();
    Ok(out)
}

fn add(a: &mut [[f64; 3]], b: &[[f64; 3]]) {
    for (x, y) in a.iter_mut().zip(b) {
        for c in 0..3 {
            x[c] += y[c];
        }
    }
}

impl Shard {
    /// The shard as a film (no auxiliary layers).
    pub fn film(&self) -> Film {
        let mut f = Film::new(self.width, self.height, Vec::new());
        f.sum.clone_from(&self.sum);
        f.splat.clone_from(&self.splat);
        f.spp = self.info.to - self.info.from;
        f
    }

    /// Write the shard (image, sums and attributes) to `path`.
    pub fn write(&self, path: &Path) -> Result<(), String> {
        write_shard(path, &self.film(), &self.info)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_ranges_parse_and_reject() {
        assert_eq!(parse_range("0..16"), Ok((0, 16)));
        assert_eq!(parse_range(" 16 .. 32 "), Ok((16, 32)));
        for bad in [
            "16",
            "5..5",
            "9..3",
            "a..4",
            "-1..4",
            "0..4294967296",
            "0...4",
        ] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
    }
}
