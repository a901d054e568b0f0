//! `bdpt-allbins`: a geometric bidirectional path tracer whose paths are evaluated for every
//! wavelength bin at once (Jung 6.5, with the Alg. 6 line 4 correction of docs/design.md §4).
//!
//! Sub-paths carry no wavelengths. A light sub-path carries a spectrum (one value per bin): the
//! emission bins, then `M·t` at each vertex (`BinOperator::apply`). A camera sub-path carries
//! importance, one row per XYZ channel, propagated with `Mᵀ·w` (`apply_transposed`). A connection
//! (s, t) is then `w_{t−1}ᵀ · t_{s−1}` times scalar directional factors: O(bins) per connection.
//! MIS uses directional pdfs only (Jung 6.4.2).

pub mod binops;
pub mod evaluate;
pub mod grid;
pub mod media;
pub mod mis;

use super::connection::{Connection, camera_term, splat};
use super::geometric::{SegmentLog, Start, Step, Trace, Walker, random_walk};
use super::{Depth, strategy_images, strategy_layer};
use crate::geometry::Ray;
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, SampleSink, Sampler};
use crate::material::Bbrrdf;
use crate::medium::Medium;
use crate::scene::{NONE, Scene};
use crate::spectrum::BinGrid;
use crate::transport::segment::{self, grey_distance_pdf};
use crate::transport::{self, Segment, Stretch, VertexKind, transmittance};
use binops::SupportedOp;
use evaluate::{Support, dot3_on, f_dir};
use glam::Vec3;
use media::BinMedia;

/// The payload of an all-bins vertex: the scalar (directional) throughput arriving at it,
/// products of f_dir·cos/pdf and 1/(pmf·pdf_area) at a light origin. The spectral part lives in
/// the integrator's bin buffers.
#[derive(Clone, Copy, Debug, Default)]
pub struct Throughput {
    pub beta: f32,
}

/// A geometric sub-path vertex (the transport layer's) with its scalar throughput.
pub type Vertex = transport::Vertex<Throughput>;

/// The pinhole as a path vertex (light tracing connects to it).
#[inline]
fn camera_vertex(scene: &Scene) -> Vertex {
    Vertex {
        p: scene.camera.origin,
        n: scene.camera.forward,
        kind: VertexKind::Camera,
        material: NONE,
        light: NONE,
        pdf_fwd: 1.0,
        pdf_rev: 0.0,
        shift: false,
        fluorescent: false,
        data: Throughput { beta: 1.0 },
    }
}

/// A light point for next-event estimation, with beta = 1/pdf.
#[inline]
fn sample_light_vertex(scene: &Scene, sampler: &mut Sampler) -> Vertex {
    let (ul, up, u2) = (sampler.next(), sampler.next(), sampler.next2());
    let mut v = Vertex::light(&scene.lights.sample_le_origin(ul, up, u2));
    v.data.beta = 1.0 / v.pdf_fwd;
    v
}

/// The integrator with its per-scene precomputation.
pub struct BdptAllbins {
    pub grid: BinGrid,
    depth: Depth,
    mis: MisHeuristic,
    /// One bin operator per material (light direction).
    ops: Vec<SupportedOp>,
    /// Binned emitted radiance per light.
    le: Vec<Vec<f32>>,
    le_support: Vec<Support>,
    /// Camera importance rows [X | Y | Z]: w_c[b] = avg_b(cmf_c) · Δλ_b / ∫ȳ.
    w: Vec<f32>,
    w_support: Support,
    /// Evaluate only this strategy (s, t), unweighted (for tests of single estimators).
    pub only: Option<(usize, usize)>,
    /// One image per strategy, named as bdpt's (`s{camera vertices}_t{light vertices}`).
    strategy_images: bool,
    /// Media tables (empty without media).
    media: BinMedia,
    /// Spectra that bins of the nominal width would average coarsely (printed by `new`).
    pub warnings: Vec<String>,
}

/// The bin buffers of one sub-path.
pub struct SideBufs {
    /// Light spectrum leaving vertex i (operator applied), `bins` values per vertex; or the
    /// camera importance rows leaving vertex j (transposed operators applied), 3·bins each.
    buf: Vec<f32>,
    support: Vec<Support>,
    /// Media: the per-bin free-flight weight of the segment reaching each vertex.
    seg_w: Vec<f32>,
    /// Media: the weight of the segment being traced, and a spare vector.
    cur_w: Vec<f32>,
    tmp: Vec<f32>,
    /// Media: the free-flight pdf of each segment sampled in reverse (towards the sub-path's
    /// start), for the MIS weights.
    drev: Vec<f32>,
}

/// Per-thread buffers, reused across samples.
pub struct Scratch {
    light: Vec<Vertex>,
    camera: Vec<Vertex>,
    lig: SideBufs,
    cam: SideBufs,
    /// Media: the sub-paths' segments, and the connection's transmittance and stretches.
    cam_log: SegmentLog,
    light_log: SegmentLog,
    conn_t: Vec<f32>,
    conn_st: Vec<Stretch>,
}

/// The camera importance rows for a grid: bin average of each CMF (or the sensor's response)
/// times the bin width, over ∫ȳ (Jung eq. 4.41 discretised with the rectangle rule).
pub fn camera_rows(scene: &Scene, grid: &BinGrid) -> Vec<f32> {
    let n = grid.len();
    let mut w = vec![0.0f32; 3 * n];
    let range = scene.observer.range;
    for b in 0..n {
        let (lo, hi) = (grid.edge(b).max(range.min), grid.edge(b + 1).min(range.max));
        if hi <= lo {
            continue;
        }
        // ∫ cmf over [lo, hi] with a 0.05 nm midpoint rule (the table is piecewise linear).
        let m = ((hi - lo) * 20.0).ceil().max(1.0) as usize;
        let h = (hi - lo) as f64 / m as f64;
        let mut acc = [0.0f64; 3];
        for k in 0..m {
            let c = scene.observer.response(lo + ((k as f64 + 0.5) * h) as f32);
            acc[0] += c.x as f64;
            acc[1] += c.y as f64;
            acc[2] += c.z as f64;
        }
        for c in 0..3 {
            w[c * n + b] = (acc[c] * h) as f32 * scene.observer.inv_y_integral;
        }
    }
    w
}

impl BdptAllbins {
    pub fn new(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        // Edges at the spectra's jumps, refined where they change fast (grid.rs).
        let (grid, warnings) = grid::scene_grid(scene, o.bin_width);
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        let mut ev = Self::with_grid(scene, o, grid)?;
        ev.warnings = warnings;
        Ok(ev)
    }

    /// The integrator on a given bin grid (`new` uses the scene's; tests compare with uniform
    /// grids).
    pub fn with_grid(scene: &Scene, o: &IntegratorOptions, grid: BinGrid) -> Result<Self, String> {
        if let Some(f) = scene.wavelength_dependent_feature() {
            return Err(format!(
                "bdpt-allbins needs wavelength-independent directional sampling; the scene has {f}"
            ));
        }
        if scene.lights.is_empty() {
            return Err("bdpt-allbins: the scene has no lights".into());
        }
        let ops = scene
            .materials
            .iter()
            .map(|m| SupportedOp::new(m.bin_operator(&grid)))
            .collect();
        let le: Vec<Vec<f32>> = scene
            .lights
            .iter()
            .map(|l| l.spectrum.to_bins(&grid))
            .collect();
        let w = camera_rows(scene, &grid);
        let media = BinMedia::new(scene, &grid);
        let le_support = le.iter().map(|l| Support::of(l)).collect();
        let w_support = Support::of_rows(&w, grid.len());
        Ok(BdptAllbins {
            grid,
            depth: Depth::new(o),
            mis: o.mis,
            ops,
            le,
            le_support,
            w,
            w_support,
            only: None,
            strategy_images: o.strategy_images,
            media,
            warnings: Vec::new(),
        })
    }
}

impl BdptAllbins {
    /// MIS weight of (s, t), or 1 when a single strategy is selected.
    #[inline]
    fn weight(
        &self,
        scene: &Scene,
        sc: &Scratch,
        s: usize,
        t: usize,
        sampled: Option<&Vertex>,
        media: Option<mis::MediaPdfs>,
    ) -> f32 {
        if self.only.is_some() {
            1.0
        } else {
            let m = media.unwrap_or_default();
            mis::weight(scene, self.mis, &sc.light, &sc.camera, s, t, sampled, m)
        }
    }

    /// Camera sub-path z0 …: rows[j] = M_jᵀ · (W_j ∘ rows[j−1]), rows[0] = w, where W_j is the
    /// per-bin free-flight weight of the segment reaching z_j (1 without media).
    fn trace_camera(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sc: &mut Scratch,
    ) -> u64 {
        let n = self.grid.len();
        let Scratch {
            camera,
            cam,
            cam_log,
            ..
        } = sc;
        camera.clear();
        let (mut z0, ray, pdf_cam) = Vertex::camera(scene, x, y);
        z0.data.beta = 1.0;
        camera.push(z0);
        cam.buf[..3 * n].copy_from_slice(&self.w);
        cam.support[0] = self.w_support;
        cam.cur_w.fill(1.0);
        cam_log.clear();
        let start = Start {
            ray,
            pdf_dir: pdf_cam,
            medium: scene.camera_medium,
        };
        let n = self.depth.camera_vertices();
        self.walk::<true>(scene, start, (camera, n, cam_log), cam, 1.0, sampler)
    }

    /// Walk a sub-path on from `start` (`geometric::random_walk`) with its bin buffers `bufs`,
    /// its first vertex's throughput `beta` and at most `max` vertices, then fold its free-flight
    /// pdfs into its vertices (media); returns the rays cast.
    fn walk<const CAMERA: bool>(
        &self,
        scene: &Scene,
        start: Start,
        (verts, max, log): (&mut Vec<Vertex>, usize, &mut SegmentLog),
        bufs: &mut SideBufs,
        beta: f32,
        sampler: &mut Sampler,
    ) -> u64 {
        let media = scene.has_media;
        let mut walker = BinWalker::<CAMERA> {
            ev: self,
            n: self.grid.len(),
            beta,
            bufs,
        };
        let trace = Trace {
            verts: &mut *verts,
            max_vertices: max,
            log: media.then_some(&mut *log),
        };
        let rays = random_walk(scene, start, trace, sampler, &mut walker);
        if media {
            fold_distances(scene, &self.media, verts, log, &mut bufs.drev);
        }
        rays
    }

    /// Light sub-path y0 …: spec[i] = M_i · (W_i ∘ spec[i−1]), spec[0] = Le.
    fn trace_light(&self, scene: &Scene, sampler: &mut Sampler, sc: &mut Scratch) -> u64 {
        let (light, lig, light_log) = (&mut sc.light, &mut sc.lig, &mut sc.light_log);
        let n = self.grid.len();
        light.clear();
        light_log.clear();
        if self.depth.light_vertices() < 2 {
            return 0;
        }
        let y0 = sample_light_vertex(scene, sampler);
        let emitter = y0.light as usize;
        let (start, e) = Start::emission(scene, &y0, sampler);
        // Le·cos/(pdf_pos·pdf_dir); the spectral Le is in `spec`.
        let beta_out = e.weight / y0.pdf_fwd;
        lig.buf[..n].copy_from_slice(&self.le[emitter]);
        lig.support[0] = self.le_support[emitter];
        light.push(y0);
        lig.cur_w.fill(1.0);
        let max = self.depth.light_vertices();
        self.walk::<false>(
            scene,
            start,
            (light, max, light_log),
            lig,
            beta_out,
            sampler,
        )
    }

    /// s = 0: the camera sub-path's vertex z(t−1) is an emitter; the weighted contribution.
    fn emitter_hit(&self, scene: &Scene, sc: &mut Scratch, t: usize) -> Option<Vec3> {
        let n = self.grid.len();
        let z = &sc.camera[t - 1];
        if !z.is_emitter() {
            return None;
        }
        let light = z.light as usize;
        let on = sc.cam.support[t - 2].intersect(self.le_support[light]);
        let zp = &sc.camera[t - 2];
        if on.is_empty() || !scene.lights[light].emits_towards(z.n, zp.p - z.p) {
            return None;
        }
        let q = &sc.cam.buf[(t - 2) * 3 * n..(t - 1) * 3 * n];
        let mut media = None;
        let le: &[f32] = if scene.has_media {
            // the free-flight weights of the last segment
            let w = &sc.cam.seg_w[(t - 1) * n..t * n];
            for ((o, a), b) in sc.conn_t.iter_mut().zip(&self.le[light]).zip(w) {
                *o = a * b;
            }
            media = Some(mis::MediaPdfs {
                cam_rev: sc.cam.drev[t - 1],
                ..mis::MediaPdfs::default()
            });
            &sc.conn_t
        } else {
            &self.le[light]
        };
        let c = dot3_on(q, le, on) * z.data.beta;
        (c != Vec3::ZERO).then(|| c * self.weight(scene, sc, 0, t, None, media))
    }

    /// Media: the per-bin transmittance of the connection from `a` (sub-path vertex `ia` of the
    /// camera sub-path if `a_camera`, else of the light sub-path) to `b` into `sc.conn_t`, and
    /// the free-flight pdfs of the connection in both directions (`None`: blocked).
    #[allow(clippy::too_many_arguments)]
    fn connection(
        &self,
        scene: &Scene,
        sc: &mut Scratch,
        a: &Vertex,
        a_camera: bool,
        ia: usize,
        b: &Vertex,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Option<(f32, f32)> {
        let d = (b.p - a.p).normalize();
        let medium = match a.kind {
            VertexKind::Camera => scene.camera_medium,
            VertexKind::Medium => a.material,
            _ if a_camera => segment::towards(sc.cam_log.segs[ia].end_media, a.n, d),
            _ if ia == 0 => segment::towards(scene.light_media(a.light as usize), a.n, d),
            _ => segment::towards(sc.light_log.segs[ia].end_media, a.n, d),
        };
        sc.conn_st.clear();
        let mut u = || sampler.next();
        let (ea, eb) = (a.endpoint(), b.endpoint());
        let (out, log) = (&mut sc.conn_t, &mut sc.conn_st);
        if !self
            .media
            .transmittance(scene, ea, eb, medium, out, log, rays, &mut u)
        {
            return None;
        }
        let rate = |id: u32| (self.media.flight[id as usize], self.media.rate[id as usize]);
        let to_b = grey_distance_pdf(scene, log, false, b.kind == VertexKind::Medium, rate);
        let to_a = grey_distance_pdf(scene, log, true, a.kind == VertexKind::Medium, rate);
        Some((to_b, to_a))
    }

    /// t = 1: connect the light vertex y(s−1) to the pinhole; the weighted contribution and its
    /// film position.
    fn light_tracing(
        &self,
        scene: &Scene,
        sc: &mut Scratch,
        s: usize,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Option<(f32, f32, Vec3)> {
        let n = self.grid.len();
        let cam = &scene.camera;
        // read in place, not copied (`connect`)
        let yv = &sc.light[s - 1];
        let on = self.w_support.intersect(sc.lig.support[s - 1]);
        if yv.material == NONE || on.is_empty() {
            return None;
        }
        let zc = camera_vertex(scene);
        let (wdir, dist2) = zc.towards(yv);
        let (px, py, _) = cam.project(wdir)?;
        let fy = f_dir(scene, yv, sc.light.get(s.wrapping_sub(2)), -wdir);
        if fy == 0.0 {
            return None;
        }
        // W_e and the geometry term without the pinhole's cosine (eq. 6.2)
        let scal = yv.data.beta * fy * camera_term(scene, wdir, dist2, yv) as f32;
        if !scene.has_media {
            let c = dot3_on(&self.w, &sc.lig.buf[(s - 1) * n..s * n], on) * scal;
            if c == Vec3::ZERO || transmittance(scene, yv.endpoint(), zc.endpoint(), rays).is_zero()
            {
                return None;
            }
            return Some((px, py, c * self.weight(scene, sc, s, 1, Some(&zc), None)));
        }
        let yv = *yv;
        let (to_cam, to_y) = self.connection(scene, sc, &yv, false, s - 1, &zc, sampler, rays)?;
        let ys = &sc.lig.buf[(s - 1) * n..s * n];
        for (o, a) in sc.conn_t.iter_mut().zip(ys) {
            *o *= a;
        }
        let c = dot3_on(&self.w, &sc.conn_t, on) * scal;
        let media = mis::MediaPdfs {
            conn_to_camera: to_cam,
            conn_to_light: to_y,
            light_rev: if s >= 2 { sc.lig.drev[s - 1] } else { 1.0 },
            ..mis::MediaPdfs::default()
        };
        (c != Vec3::ZERO).then(|| {
            (
                px,
                py,
                c * self.weight(scene, sc, s, 1, Some(&zc), Some(media)),
            )
        })
    }

    /// s ≥ 1, t ≥ 2: connect z(t−1) to y(s−1) (s = 1: a fresh light point, sampler: four
    /// values); the weighted contribution.
    fn connect(
        &self,
        scene: &Scene,
        sc: &mut Scratch,
        s: usize,
        t: usize,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Option<Vec3> {
        let n = self.grid.len();
        // The vertices are read where they are, not copied first: a copy is stored piece by
        // piece and then read back in wider loads (the normal as one vector), which wait for
        // the stores to complete (bdpt-allbins on cornell-box 0.91× as fast with copies).
        let z = &sc.camera[t - 1];
        if z.material == NONE || sc.cam.support[t - 1].is_empty() {
            return None;
        }
        if s >= 2
            && sc.cam.support[t - 1]
                .intersect(sc.lig.support[s - 1])
                .is_empty()
        {
            return None;
        }
        let zp = &sc.camera[t - 2];
        let fresh = (s == 1).then(|| sample_light_vertex(scene, sampler));
        let (yv, ysup, yprev) = match &fresh {
            Some(y) => (y, self.le_support[y.light as usize], None),
            None => (
                &sc.light[s - 1],
                sc.lig.support[s - 1],
                sc.light.get(s.wrapping_sub(2)),
            ),
        };
        let on = sc.cam.support[t - 1].intersect(ysup);
        if on.is_empty() || !matches!(yv.kind, VertexKind::Light) && yv.material == NONE {
            return None;
        }
        // The connection z → y: lobes at both ends and the geometry term (Veach eq. 8.3).
        let conn = Connection::new(z, yv);
        let w = conn.seg.w;
        let fz = f_dir(scene, z, Some(zp), w);
        let fy = f_dir(scene, yv, yprev, -w);
        let scal = fz * fy * conn.g32() * z.data.beta * yv.data.beta;
        if scal == 0.0 {
            return None;
        }
        let sampled = (s == 1).then_some(yv);
        let q = &sc.cam.buf[(t - 1) * 3 * n..t * 3 * n];
        let ys: &[f32] = if s == 1 {
            &self.le[yv.light as usize]
        } else {
            &sc.lig.buf[(s - 1) * n..s * n]
        };
        if !scene.has_media {
            let c = dot3_on(q, ys, on) * scal;
            if c == Vec3::ZERO || transmittance(scene, z.endpoint(), yv.endpoint(), rays).is_zero()
            {
                return None;
            }
            return Some(c * self.weight(scene, sc, s, t, sampled, None));
        }
        // the connection through media writes the scratch buffers: copies of the two ends
        let (z, yv) = (*z, *yv);
        let sampled = (s == 1).then_some(&yv);
        let (to_y, to_z) = self.connection(scene, sc, &z, true, t - 1, &yv, sampler, rays)?;
        let ys: &[f32] = if s == 1 {
            &self.le[yv.light as usize]
        } else {
            &sc.lig.buf[(s - 1) * n..s * n]
        };
        for (o, a) in sc.conn_t.iter_mut().zip(ys) {
            *o *= a;
        }
        let q = &sc.cam.buf[(t - 1) * 3 * n..t * 3 * n];
        let c = dot3_on(q, &sc.conn_t, on) * scal;
        let media = mis::MediaPdfs {
            conn_to_light: to_y,
            conn_to_camera: to_z,
            cam_rev: sc.cam.drev[t - 1],
            light_rev: if s >= 2 { sc.lig.drev[s - 1] } else { 1.0 },
        };
        (c != Vec3::ZERO).then(|| c * self.weight(scene, sc, s, t, sampled, Some(media)))
    }
}

/// The all-bins side of a sub-path walk: the light spectrum (light paths) or the importance
/// rows (camera paths) through each vertex's bin operator, and in media the per-bin free-flight
/// weights of the segments.
struct BinWalker<'a, const CAMERA: bool> {
    ev: &'a BdptAllbins,
    n: usize,
    /// The scalar throughput stored at each new vertex.
    beta: f32,
    bufs: &'a mut SideBufs,
}

impl<const CAMERA: bool> Walker<Throughput> for BinWalker<'_, CAMERA> {
    #[inline]
    fn travel(
        &mut self,
        id: u32,
        medium: &Medium,
        ray: &Ray,
        t_max: f32,
        _: &[Vertex],
        sampler: &mut Sampler,
    ) -> Option<f32> {
        let mut u = || sampler.next();
        let w = &mut self.bufs.cur_w;
        self.ev.media.travel(id, medium, ray, t_max, w, &mut u)
    }

    #[inline]
    fn on_vertex(
        &mut self,
        verts: &mut [Vertex],
        seg: Option<&mut Segment>,
        _: &mut Sampler,
    ) -> Step {
        let n = self.n;
        let j = verts.len() - 1;
        verts[j].data.beta = self.beta;
        let b = &mut *self.bufs;
        let media = seg.is_some();
        if media {
            b.seg_w[j * n..(j + 1) * n].copy_from_slice(&b.cur_w);
            b.cur_w.fill(1.0);
        }
        let v = verts[j];
        if !v.scatters() {
            // Camera paths keep an emitter they hit (s = 0); light paths cannot use it.
            return if CAMERA { Step::Stop } else { Step::Discard };
        }
        // The last camera vertex (j = max_depth) is only used by s = 0.
        if CAMERA && j + 1 >= self.ev.depth.camera_vertices() {
            return Step::Stop;
        }
        let op = if v.kind == VertexKind::Medium {
            &self.ev.media.ops[v.material as usize]
        } else {
            &self.ev.ops[v.material as usize]
        };
        let stride = if CAMERA { 3 * n } else { n };
        let (prev, cur) = b.buf.split_at_mut(j * stride);
        let prev = &prev[(j - 1) * stride..];
        let cur = &mut cur[..stride];
        let input: &[f32] = if media {
            let w = &b.seg_w[j * n..(j + 1) * n];
            for (k, (o, x)) in b.tmp[..stride].iter_mut().zip(prev).enumerate() {
                *o = x * w[k % n];
            }
            &b.tmp[..stride]
        } else {
            prev
        };
        let ps = b.support[j - 1];
        b.support[j] = if CAMERA {
            op.apply_transposed3(input, ps, cur, n)
        } else {
            // Stop once the spectrum is zero in every bin (Jung 8.2).
            op.apply(input, ps, cur)
        };
        if b.support[j].is_empty() {
            Step::Stop
        } else {
            Step::Continue
        }
    }

    #[inline]
    fn needs_far(&self) -> bool {
        false
    }
}

/// Media: multiply each sampled segment's free-flight pdfs (the all-bins tracking's, which do
/// not depend on wavelength) into the area pdfs of the vertices at its ends; `drev[j]` keeps the
/// reverse one of the segment reaching vertex j for the MIS of connections.
fn fold_distances(
    scene: &Scene,
    media: &BinMedia,
    verts: &mut [Vertex],
    log: &SegmentLog,
    drev: &mut [f32],
) {
    let rate = |id: u32| (media.flight[id as usize], media.rate[id as usize]);
    for j in 1..verts.len() {
        let seg = log.segs[j];
        let st = seg.stretches(&log.stretches);
        let fwd = grey_distance_pdf(scene, st, false, verts[j].kind == VertexKind::Medium, rate);
        let rev = grey_distance_pdf(
            scene,
            st,
            true,
            verts[j - 1].kind == VertexKind::Medium,
            rate,
        );
        verts[j].pdf_fwd *= fwd;
        verts[j - 1].pdf_rev *= rev;
        drev[j] = rev;
    }
}

impl Integrator for BdptAllbins {
    type Scratch = Scratch;

    fn scratch(&self, _: &Scene) -> Scratch {
        let n = self.grid.len();
        let v = self.depth.capacity();
        let side = |stride: usize| SideBufs {
            buf: vec![0.0; v * stride],
            support: vec![Support::EMPTY; v],
            seg_w: vec![1.0; v * n],
            cur_w: vec![1.0; n],
            tmp: vec![0.0; 3 * n],
            drev: vec![1.0; v],
        };
        Scratch {
            light: Vec::with_capacity(v),
            camera: Vec::with_capacity(v),
            lig: side(n),
            cam: side(3 * n),
            cam_log: SegmentLog::default(),
            light_log: SegmentLog::default(),
            conn_t: vec![1.0; n],
            conn_st: Vec::new(),
        }
    }

    fn aux_layers(&self) -> Vec<String> {
        strategy_images(self.strategy_images, self.depth)
    }

    fn sample(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sc: &mut Scratch,
        sink: &mut SampleSink,
    ) {
        let mut rays = self.trace_camera(scene, x, y, sampler, sc);
        rays += self.trace_light(scene, sampler, sc);
        let mut value = Vec3::ZERO;
        for t in 1..=sc.camera.len() {
            for s in 0..=sc.light.len() {
                let segments = s + t - 1;
                if segments == 0 || !self.depth.allows(s, t) || (s == 1 && t == 1) {
                    continue;
                }
                if self.only.is_some_and(|o| o != (s, t)) {
                    continue;
                }
                // bdpt's strategy-image order: (camera vertices, light vertices)
                let layer = strategy_layer(t, s);
                if t == 1 {
                    let Some((px, py, c)) = self.light_tracing(scene, sc, s, sampler, &mut rays)
                    else {
                        continue;
                    };
                    // bdpt's strategy-image order: (camera vertices, light vertices)
                    if splat(sink, (t, s), (px, py), c, self.strategy_images) {
                        sink.stats.contribution(segments);
                    }
                    continue;
                }
                let c = if s == 0 {
                    self.emitter_hit(scene, sc, t)
                } else {
                    self.connect(scene, sc, s, t, sampler, &mut rays)
                };
                let Some(c) = c else { continue };
                value += c;
                if self.strategy_images {
                    sink.aux(layer, sink.pixel, c);
                }
                sink.stats.contribution(segments);
            }
        }
        sink.stats.rays += rays;
        sink.add(value);
    }
}
