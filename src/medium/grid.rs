//! Heterogeneous density on a regular grid: Mitsuba 3's binary `.vol` files (read and write)
//! and trilinear lookup with Mitsuba 3's `gridvolume` convention.
//!
//! Sample placement (Mitsuba 3 `src/volumes/grid.cpp`, whose default `filter_type` is
//! `trilinear` and `wrap_mode` is `clamp`, evaluating through Dr.Jit's `Texture::eval_nonaccel`
//! in `include/drjit/texture.h`): voxel samples sit at cell centres, `(i + ½) / res` of the box.
//! A point at unit-box coordinate `u` is looked up at `pos = u·res − ½`, between the samples
//! `⌊pos⌋` and `⌊pos⌋ + 1` with weights `pos − ⌊pos⌋`, and sample indices are clamped to
//! `[0, res − 1]` (clamp to edge). So the density is constant-extrapolated in the outer half
//! voxel. (pbrt-v4's `SampledGrid::Lookup` also centres samples but reads zero beyond the edge.)
//! Outside the bounding box the density here is 0.
//!
//! Bounding box: Mitsuba 3 ignores the box stored in the file unless the `gridvolume` sets
//! `use_grid_bbox = true` (by default the grid fills the unit cube under `to_world`); here the
//! file's box is always used, so a Mitsuba scene of the same file sets `use_grid_bbox` or the
//! equivalent `to_world`.

use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

use glam::Vec3;

/// Most voxels a `.vol` file may hold (512³); checked before anything is allocated.
pub const MAX_VOXELS: u64 = 512 * 512 * 512;

/// Bytes before the voxel data: "VOL", version, encoding, 3 resolutions, channels, 6 floats.
const HEADER_BYTES: u64 = 48;

/// A scalar density on `res` voxels filling the box `[min, max]`, x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    pub res: [usize; 3],
    pub min: Vec3,
    pub max: Vec3,
    /// `data[(z·res_y + y)·res_x + x]`, finite and ≥ 0.
    data: Vec<f32>,
}

/// What the 48-byte header of a valid `.vol` file says.
struct Header {
    res: [usize; 3],
    min: Vec3,
    max: Vec3,
    voxels: u64,
}

impl DensityGrid {
    /// A grid of `res` voxels over `[min, max]` whose voxel at centre `p` holds `f(p)`
    /// (samples sit at voxel centres, the convention of [`DensityGrid::density`]).
    ///
    /// Panics on a zero resolution, an empty or non-finite box, or a negative or non-finite value.
    pub fn from_fn(res: [usize; 3], min: Vec3, max: Vec3, mut f: impl FnMut(Vec3) -> f32) -> Self {
        assert!(
            res.iter().all(|&n| n > 0),
            "DensityGrid: zero resolution {res:?}"
        );
        assert!(
            min.is_finite() && max.is_finite() && min.cmplt(max).all(),
            "DensityGrid: empty or non-finite box {min} .. {max}"
        );
        let n = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let mut data = Vec::with_capacity(res[0] * res[1] * res[2]);
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    let u = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / n;
                    let v = f(min + u * (max - min));
                    assert!(v >= 0.0 && v.is_finite(), "DensityGrid: density {v} at {u}");
                    data.push(v);
                }
            }
        }
        Self {
            res,
            min,
            max,
            data,
        }
    }

    /// The voxel values, `data[(z·res_y + y)·res_x + x]`.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The largest voxel value (0 for an all-zero grid); trilinear lookups never exceed it.
    pub fn max_density(&self) -> f32 {
        self.data.iter().copied().fold(0.0, f32::max)
    }

    /// Trilinear density at `p` with Mitsuba 3's convention (module doc); 0 outside the box.
    pub fn density(&self, p: Vec3) -> f32 {
        let u = (p - self.min) / (self.max - self.min);
        if !(u.cmpge(Vec3::ZERO).all() && u.cmple(Vec3::ONE).all()) {
            return 0.0; // outside, or NaN
        }
        let (mut i0, mut i1, mut w) = ([0usize; 3], [0usize; 3], [0f32; 3]);
        for a in 0..3 {
            // Dr.Jit `eval_nonaccel`: pos = u·res − ½, weights pos − ⌊pos⌋, clamped indices.
            let pos = u[a] * self.res[a] as f32 - 0.5;
            let base = pos.floor();
            w[a] = pos - base;
            let last = self.res[a] as i64 - 1;
            i0[a] = (base as i64).clamp(0, last) as usize;
            i1[a] = (base as i64 + 1).clamp(0, last) as usize;
        }
        let v = |x: usize, y: usize, z: usize| self.data[(z * self.res[1] + y) * self.res[0] + x];
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let along_x = |y, z| lerp(v(i0[0], y, z), v(i1[0], y, z), w[0]);
        let z0 = lerp(along_x(i0[1], i0[2]), along_x(i1[1], i0[2]), w[1]);
        let z1 = lerp(along_x(i0[1], i1[2]), along_x(i1[1], i1[2]), w[1]);
        lerp(z0, z1, w[2])
    }

    /// The part of `[t_min, t_max]` where `o + t·d` is inside the box, if not empty.
    pub fn clip(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let (o, d) = to_unit(self.min, self.max, o, d);
        clip_unit_box(o, d, t_min, t_max)
    }

    /// Read a Mitsuba 3 `.vol` file with one float32 channel (format: Mitsuba 3
    /// `src/volumes/grid.cpp` documentation and `src/render/volumegrid.cpp`, `VolumeGrid::read`).
    /// The error says what is wrong; the caller adds the file and the scene field.
    pub fn read_vol(path: &Path) -> Result<DensityGrid, String> {
        let file = std::fs::File::open(path).map_err(|e| format!("cannot open the file: {e}"))?;
        let len = file
            .metadata()
            .map_err(|e| format!("cannot read the file's size: {e}"))?
            .len();
        if len < HEADER_BYTES {
            return Err(format!(
                "the file holds {len} bytes, less than the {HEADER_BYTES}-byte .vol header"
            ));
        }
        let mut r = BufReader::new(file);
        let mut head = [0u8; HEADER_BYTES as usize];
        r.read_exact(&mut head)
            .map_err(|e| format!("cannot read the header: {e}"))?;
        let h = parse_header(&head)?;
        // Check the length before allocating: the header alone cannot make us reserve memory.
        let (want, have) = (h.voxels * 4, len - HEADER_BYTES);
        let [x, y, z] = h.res;
        if have < want {
            return Err(format!(
                "header says {x}×{y}×{z} voxels ({want} bytes of data) but the file holds \
                 {have} bytes of data (truncated)"
            ));
        }
        if have > want {
            return Err(format!(
                "header says {x}×{y}×{z} voxels ({want} bytes of data) but the file holds \
                 {have} bytes of data ({} trailing bytes)",
                have - want
            ));
        }
        let mut data = Vec::with_capacity(h.voxels as usize);
        let mut b = [0u8; 4];
        for i in 0..h.voxels as usize {
            r.read_exact(&mut b)
                .map_err(|e| format!("cannot read voxel {i}: {e}"))?;
            let v = f32::from_le_bytes(b);
            if !(v >= 0.0 && v.is_finite()) {
                let (vx, vy, vz) = (i % x, i / x % y, i / (x * y));
                return Err(format!(
                    "voxel {i} (x {vx}, y {vy}, z {vz}) has density {v}; densities must be \
                     finite and ≥ 0"
                ));
            }
            data.push(v);
        }
        Ok(DensityGrid {
            res: h.res,
            min: h.min,
            max: h.max,
            data,
        })
    }

    /// Write a Mitsuba 3 `.vol` file (version 3, float32, one channel, little-endian), the
    /// layout `VolumeGrid::write` of Mitsuba 3 `src/render/volumegrid.cpp` writes.
    pub fn write_vol(&self, path: &Path) -> std::io::Result<()> {
        let mut w = BufWriter::new(std::fs::File::create(path)?);
        w.write_all(b"VOL\x03")?;
        let int = |n: usize| {
            i32::try_from(n).map_err(|_| std::io::Error::other(format!("{n} does not fit an i32")))
        };
        for n in [
            1,
            int(self.res[0])?,
            int(self.res[1])?,
            int(self.res[2])?,
            1,
        ] {
            w.write_all(&n.to_le_bytes())?;
        }
        for v in self.min.to_array().into_iter().chain(self.max.to_array()) {
            w.write_all(&v.to_le_bytes())?;
        }
        for v in &self.data {
            w.write_all(&v.to_le_bytes())?;
        }
        w.flush()
    }
}

/// Check the 48-byte header: magic, version 3, float32, one channel, a sane resolution and box.
fn parse_header(h: &[u8; HEADER_BYTES as usize]) -> Result<Header, String> {
    let int = |i: usize| i32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
    let float = |i: usize| f32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
    if &h[..3] != b"VOL" {
        return Err(format!(
            "not a Mitsuba .vol file: it starts with {:?}, not \"VOL\"",
            String::from_utf8_lossy(&h[..3])
        ));
    }
    if h[3] != 3 {
        return Err(format!(
            "unsupported .vol version {}: only version 3 is read",
            h[3]
        ));
    }
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!(
            "unsupported .vol encoding {encoding}: only 1 (float32) is read"
        ));
    }
    let channels = int(20);
    if channels != 1 {
        return Err(format!(
            "the grid has {channels} channels; a density grid needs exactly 1"
        ));
    }
    let r = [int(8), int(12), int(16)];
    if r.iter().any(|&n| n <= 0) {
        return Err(format!(
            "resolution {}×{}×{} has a zero or negative size",
            r[0], r[1], r[2]
        ));
    }
    let voxels: u128 = r.iter().map(|&n| n as u128).product();
    if voxels > MAX_VOXELS as u128 {
        return Err(format!(
            "resolution {}×{}×{} has {voxels} voxels, more than the {MAX_VOXELS} (512³) allowed",
            r[0], r[1], r[2]
        ));
    }
    let min = Vec3::new(float(24), float(28), float(32));
    let max = Vec3::new(float(36), float(40), float(44));
    if !(min.is_finite() && max.is_finite()) {
        return Err(format!("bounding box {min} .. {max} is not finite"));
    }
    if let Some(a) = (0..3).find(|&a| !(min[a] < max[a])) {
        return Err(format!(
            "bounding box {min} .. {max} is empty or inverted along {}",
            ["x", "y", "z"][a]
        ));
    }
    Ok(Header {
        res: r.map(|n| n as usize),
        min,
        max,
        voxels: voxels as u64,
    })
}

/// The ray in the box's unit coordinates; the ray parameter t is unchanged.
fn to_unit(min: Vec3, max: Vec3, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
    ((o - min) / (max - min), d / (max - min))
}

/// The part of `[t_min, t_max]` where `o + t·d` lies in `[0, 1]³` (slab test, pbrt-v4
/// `Bounds3::IntersectP`, with axis-parallel rays handled explicitly); `None` if empty or NaN.
fn clip_unit_box(o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
    if !(o.is_finite() && d.is_finite() && t_min <= t_max) {
        return None;
    }
    let (mut t0, mut t1) = (t_min, t_max);
    for a in 0..3 {
        if d[a] == 0.0 {
            // Parallel to the slab (d = 0 or −0): inside it for every t, or never.
            if !(0.0..=1.0).contains(&o[a]) {
                return None;
            }
            continue;
        }
        let (near, far) = ((0.0 - o[a]) / d[a], (1.0 - o[a]) / d[a]);
        t0 = t0.max(near.min(far));
        t1 = t1.min(near.max(far));
    }
    (t0 < t1).then_some((t0, t1))
}
