//! Heterogeneous density on a regular grid: Mitsuba 3's binary `.vol` files (read and write),
//! trilinear lookup with Mitsuba 3's `gridvolume` convention, a coarse majorant grid walked by a
//! DDA (pbrt-v4's `MajorantGrid` and `DDAMajorantIterator`), ratio-tracking transmittance and a
//! ray-marched reference for tests.
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

/// Majorant cells per axis (pbrt-v4's `GridMedium` uses a 16³ `MajorantGrid`).
pub const MAJORANT_RES: usize = 16;

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
        let (file, len) = crate::io::input::open(path, crate::io::input::VOL)?;
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

/// The largest density the trilinear lookup takes in each of `res³` cells of a grid's box
/// (pbrt-v4 `MajorantGrid`, filled as `GridMedium` does with `SampledGrid::MaxValue`).
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    pub res: usize,
    min: Vec3,
    max: Vec3,
    /// `data[(z·res + y)·res + x]`.
    data: Vec<f32>,
}

/// Voxel samples that weigh on some point of majorant cell `c` of `m` along an axis of `n`
/// samples: pbrt-v4 `SampledGrid::MaxValue`'s ⌊a·n − ½⌋ ..= ⌊b·n − ½⌋ + 1 (clamped) for the cell
/// [a, b], widened by 1/1000 voxel so rounding at the ends of DDA segments stays covered.
fn footprint(c: usize, m: usize, n: usize) -> (usize, usize) {
    let (a, b) = (c as f64 / m as f64, (c + 1) as f64 / m as f64);
    let lo = (a * n as f64 - 0.5 - 1e-3).floor();
    let hi = (b * n as f64 - 0.5 + 1e-3).floor() + 1.0;
    (lo.max(0.0) as usize, hi.min(n as f64 - 1.0) as usize)
}

impl MajorantGrid {
    /// Majorants of `grid` on `res³` cells ([`MAJORANT_RES`] is the usual `res`).
    pub fn new(grid: &DensityGrid, res: usize) -> Self {
        assert!(res > 0, "MajorantGrid: zero resolution");
        let spans: [Vec<(usize, usize)>; 3] =
            std::array::from_fn(|a| (0..res).map(|c| footprint(c, res, grid.res[a])).collect());
        let mut data = Vec::with_capacity(res * res * res);
        for &(z0, z1) in &spans[2] {
            for &(y0, y1) in &spans[1] {
                for &(x0, x1) in &spans[0] {
                    let mut m = 0.0f32;
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            let row = (z * grid.res[1] + y) * grid.res[0];
                            m = grid.data[row + x0..=row + x1]
                                .iter()
                                .fold(m, |m, &v| m.max(v));
                        }
                    }
                    data.push(m);
                }
            }
        }
        Self {
            res,
            min: grid.min,
            max: grid.max,
            data,
        }
    }

    /// The majorant of cell `[x, y, z]`.
    pub fn cell(&self, [x, y, z]: [usize; 3]) -> f32 {
        self.data[(z * self.res + y) * self.res + x]
    }

    /// The cells `o + t·d` crosses for t in `[t_min, t_max]`, as `(t0, t1, majorant)` in order
    /// along the ray: contiguous, non-empty, and covering exactly the part of the interval
    /// inside the box (nothing if the ray misses). `d` need not be normalised.
    pub fn segments(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Segments<'_> {
        let (o, d) = to_unit(self.min, self.max, o, d);
        let mut s = Segments {
            grid: self,
            o,
            d,
            t: 0.0,
            t_end: 0.0,
            cell: [0; 3],
            step: [0; 3],
            next: [f32::INFINITY; 3],
            steps_left: 3 * self.res + 4,
        };
        let Some((t0, t1)) = clip_unit_box(o, d, t_min, t_max) else {
            return s; // t = t_end: empty
        };
        (s.t, s.t_end) = (t0, t1);
        // pbrt-v4 `DDAMajorantIterator`: the cell of the entry point, then per axis the t of the
        // next cell boundary (here computed from the origin each time, not accumulated).
        let p = o + d * t0;
        let last = self.res as i64 - 1;
        for a in 0..3 {
            s.cell[a] = ((p[a] * self.res as f32).floor() as i64).clamp(0, last);
            s.step[a] = if d[a] > 0.0 {
                1
            } else if d[a] < 0.0 {
                -1
            } else {
                0 // d = 0 or −0: never crosses a boundary on this axis
            };
            s.next[a] = s.crossing(a);
        }
        s
    }
}

/// The DDA walk of [`MajorantGrid::segments`].
#[derive(Clone, Debug)]
pub struct Segments<'a> {
    grid: &'a MajorantGrid,
    /// The ray in the box's unit coordinates.
    o: Vec3,
    d: Vec3,
    /// Start of the next segment and end of the clipped interval.
    t: f32,
    t_end: f32,
    cell: [i64; 3],
    step: [i64; 3],
    /// The t at which the ray leaves the current cell along each axis (∞ if never).
    next: [f32; 3],
    /// Bound on the walk: each axis moves at most `res` times.
    steps_left: usize,
}

impl Segments<'_> {
    /// The t of the current cell's exit plane along axis `a` (∞ for a parallel ray).
    fn crossing(&self, a: usize) -> f32 {
        let plane = match self.step[a] {
            1 => self.cell[a] + 1,
            -1 => self.cell[a],
            _ => return f32::INFINITY,
        };
        (plane as f32 / self.grid.res as f32 - self.o[a]) / self.d[a]
    }
}

impl Iterator for Segments<'_> {
    type Item = (f32, f32, f32);

    fn next(&mut self) -> Option<(f32, f32, f32)> {
        while self.t < self.t_end && self.steps_left > 0 {
            self.steps_left -= 1;
            let a = (0..3)
                .min_by(|&i, &j| self.next[i].total_cmp(&self.next[j]))
                .unwrap_or(0);
            let t0 = self.t;
            let majorant = self.grid.cell(self.cell.map(|c| c as usize));
            if self.next[a] >= self.t_end || self.steps_left == 0 {
                self.t = self.t_end; // the last cell runs to the end of the interval
            } else {
                self.t = self.next[a].max(t0);
                self.cell[a] += self.step[a];
                if (0..self.grid.res as i64).contains(&self.cell[a]) {
                    self.next[a] = self.crossing(a);
                } else {
                    // Rounding left the grid before t_end: stay in the edge cell to the end.
                    self.cell[a] -= self.step[a];
                    self.next[a] = f32::INFINITY;
                }
            }
            if self.t > t0 {
                return Some((t0, self.t, majorant));
            }
        }
        None
    }
}

/// Transmittance along `o + t·d`, t in `[t_min, t_max]`, by ratio tracking over the majorant
/// cells (Novák, Selle and Jarosz 2014, "Residual ratio tracking for estimating attenuation in
/// participating media", SIGGRAPH Asia; pbrt-v4 `TraceTransmittance`). The extinction is
/// `sigma_t · density` per unit of world distance, so a non-unit `d` counts with its length.
/// `rng` returns uniform numbers in [0, 1). Unbiased; the estimate lies in [0, 1].
#[allow(clippy::too_many_arguments)]
pub fn ratio_tracking(
    grid: &DensityGrid,
    maj: &MajorantGrid,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    sigma_t: f32,
    mut rng: impl FnMut() -> f32,
) -> f32 {
    let speed = d.length(); // world distance per unit t
    let mut tr = 1.0f32;
    for (t0, t1, m) in maj.segments(o, d, t_min, t_max) {
        let sigma_maj = sigma_t * m * speed; // majorant extinction per unit t
        if !(sigma_maj > 0.0) {
            continue; // nothing to collide with in this cell
        }
        let mut t = t0;
        loop {
            // Exponential free flight with the majorant (pbrt-v4 `SampleExponential`).
            t -= (1.0 - rng()).ln() / sigma_maj;
            if !(t < t1) {
                break;
            }
            // Ratio tracking (Novák et al. 2014): T ← T · (1 − σ_t(x)/σ̄) = T · (1 − ρ(x)/ρ̄).
            tr *= 1.0 - grid.density(o + d * t) / m;
        }
        if tr <= 0.0 {
            return 0.0;
        }
    }
    tr
}

/// Reference transmittance `exp(−∫ sigma_t·density ds)` along `o + t·d`, t in
/// `[t_min, t_max]`, by the midpoint rule with `steps` steps over the part inside the box.
pub fn ray_marched_transmittance(
    grid: &DensityGrid,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    sigma_t: f32,
    steps: usize,
) -> f32 {
    assert!(steps > 0, "ray_marched_transmittance: zero steps");
    let speed = d.length() as f64;
    let Some((t0, t1)) = grid.clip(o, d, t_min, t_max) else {
        return 1.0;
    };
    if speed == 0.0 {
        return 1.0;
    }
    let h = (t1 as f64 - t0 as f64) / steps as f64;
    let sum: f64 = (0..steps)
        .map(|i| {
            let t = (t0 as f64 + (i as f64 + 0.5) * h) as f32;
            grid.density(o + d * t) as f64
        })
        .sum();
    (-(sigma_t as f64) * speed * h * sum).exp() as f32
}
