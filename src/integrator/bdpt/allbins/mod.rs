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
pub mod mis;

use super::geometric::{Step, random_walk};
use super::{strategy_layer, strategy_layer_names};
use crate::geometry::ray::spawn_ray;
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, SampleSink, Sampler};
use crate::material::Bbrrdf;
use crate::scene::{NONE, Scene};
use crate::spectrum::BinGrid;
use crate::spectrum::cie::cmf;
use crate::transport::{self, VertexKind, transmittance};
use binops::SupportedOp;
use evaluate::{Support, dot3_on, f_dir, pinhole_we};
use glam::Vec3;

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
    max_depth: usize,
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
}

/// Per-thread buffers, reused across samples.
pub struct Scratch {
    light: Vec<Vertex>,
    camera: Vec<Vertex>,
    /// Light spectrum leaving vertex i (material applied), `bins` values per vertex.
    spec: Vec<f32>,
    /// Importance rows leaving camera vertex j (transposed operators applied), 3·bins each.
    rows: Vec<f32>,
    spec_support: Vec<Support>,
    rows_support: Vec<Support>,
}

/// The camera importance rows for a grid: bin average of each CMF times the bin width, over
/// ∫ȳ (Jung eq. 4.41 discretised with the rectangle rule).
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
            let c = cmf(lo + ((k as f64 + 0.5) * h) as f32);
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
        if scene.has_media {
            return Err(crate::integrator::media_not_supported("bdpt-allbins"));
        }
        if let Some(f) = scene.wavelength_dependent_feature() {
            return Err(format!(
                "bdpt-allbins needs wavelength-independent directional sampling; the scene has {f}"
            ));
        }
        if scene.lights.is_empty() {
            return Err("bdpt-allbins: the scene has no lights".into());
        }
        let grid = BinGrid::new(scene.domain, o.bin_width);
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
        let le_support = le.iter().map(|l| Support::of(l)).collect();
        let w_support = Support::of_rows(&w, grid.len());
        Ok(BdptAllbins {
            grid,
            max_depth: o.max_depth as usize,
            mis: o.mis,
            ops,
            le,
            le_support,
            w,
            w_support,
            only: None,
            strategy_images: o.strategy_images,
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
    ) -> f32 {
        if self.only.is_some() {
            1.0
        } else {
            mis::weight(scene, self.mis, &sc.light, &sc.camera, s, t, sampled)
        }
    }

    /// Camera sub-path z0 …: rows[j] = M_jᵀ · rows[j−1], rows[0] = w.
    fn trace_camera(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        sc: &mut Scratch,
    ) -> u64 {
        let n = self.grid.len();
        let max_depth = self.max_depth;
        let Scratch {
            camera,
            rows,
            rows_support,
            ..
        } = sc;
        camera.clear();
        let (mut z0, ray, pdf_cam) = Vertex::camera(scene, x, y);
        z0.data.beta = 1.0;
        camera.push(z0);
        rows[..3 * n].copy_from_slice(&self.w);
        rows_support[0] = self.w_support;
        let mut rays = 0u64;
        random_walk(
            scene,
            ray,
            pdf_cam,
            camera,
            max_depth + 1,
            sampler,
            &mut rays,
            |verts, _| {
                let j = verts.len() - 1;
                verts[j].data.beta = 1.0;
                let m = verts[j].material;
                // The last vertex (j = max_depth) is only used by s = 0.
                if m == NONE || j >= max_depth {
                    return Step::Stop;
                }
                let (prev, cur) = rows.split_at_mut(j * 3 * n);
                let prev = &prev[(j - 1) * 3 * n..];
                let cur = &mut cur[..3 * n];
                rows_support[j] =
                    self.ops[m as usize].apply_transposed3(prev, rows_support[j - 1], cur, n);
                if rows_support[j].is_empty() {
                    Step::Stop
                } else {
                    Step::Continue
                }
            },
        );
        rays
    }

    /// Light sub-path y0 …: spec[i] = M_i · spec[i−1], spec[0] = Le.
    fn trace_light(&self, scene: &Scene, sampler: &mut Sampler, sc: &mut Scratch) -> u64 {
        let n = self.grid.len();
        let Scratch {
            light,
            spec,
            spec_support,
            ..
        } = sc;
        light.clear();
        if self.max_depth < 2 {
            return 0;
        }
        let y0 = sample_light_vertex(scene, sampler);
        let l = y0.light as usize;
        let e = scene.lights.sample_le_direction(l, y0.n, sampler.next2());
        let (lray, pdf_dir) = (spawn_ray(y0.p, y0.n, e.w), e.pdf_dir);
        // Le·cos/(pdf_pos·pdf_dir); the spectral Le is in `spec`.
        let beta_out = e.weight / y0.pdf_fwd;
        spec[..n].copy_from_slice(&self.le[l]);
        spec_support[0] = self.le_support[l];
        light.push(y0);
        let mut rays = 0u64;
        random_walk(
            scene,
            lray,
            pdf_dir,
            light,
            self.max_depth,
            sampler,
            &mut rays,
            |verts, _| {
                let i = verts.len() - 1;
                let m = verts[i].material;
                if m == NONE {
                    // Black: cannot scatter or connect.
                    return Step::Discard;
                }
                verts[i].data.beta = beta_out;
                let (prev, cur) = spec.split_at_mut(i * n);
                let cur = &mut cur[..n];
                // Stop once the spectrum is zero in every bin (Jung 8.2).
                spec_support[i] =
                    self.ops[m as usize].apply(&prev[(i - 1) * n..], spec_support[i - 1], cur);
                if spec_support[i].is_empty() {
                    Step::Stop
                } else {
                    Step::Continue
                }
            },
        );
        rays
    }

    /// s = 0: the camera sub-path's vertex z(t−1) is an emitter; the weighted contribution.
    fn emitter_hit(&self, scene: &Scene, sc: &Scratch, t: usize) -> Option<Vec3> {
        let n = self.grid.len();
        let z = &sc.camera[t - 1];
        if !z.is_emitter() {
            return None;
        }
        let on = sc.rows_support[t - 2].intersect(self.le_support[z.light as usize]);
        let zp = &sc.camera[t - 2];
        if on.is_empty() || !scene.lights[z.light as usize].emits_towards(z.n, zp.p - z.p) {
            return None;
        }
        let q = &sc.rows[(t - 2) * 3 * n..(t - 1) * 3 * n];
        let c = dot3_on(q, &self.le[z.light as usize], on) * z.data.beta;
        (c != Vec3::ZERO).then(|| c * self.weight(scene, sc, 0, t, None))
    }

    /// t = 1: connect the light vertex y(s−1) to the pinhole; the weighted contribution and its
    /// film position.
    fn light_tracing(
        &self,
        scene: &Scene,
        sc: &Scratch,
        s: usize,
        rays: &mut u64,
    ) -> Option<(f32, f32, Vec3)> {
        let n = self.grid.len();
        let cam = &scene.camera;
        let yv = &sc.light[s - 1];
        let on = self.w_support.intersect(sc.spec_support[s - 1]);
        if yv.material == NONE || on.is_empty() {
            return None;
        }
        let zc = camera_vertex(scene);
        let (wdir, dist2) = zc.towards(yv);
        let (px, py, cos) = cam.project(wdir)?;
        let fy = f_dir(scene, yv, sc.light.get(s.wrapping_sub(2)), -wdir);
        if fy == 0.0 {
            return None;
        }
        let g = cos * yv.abs_cos(wdir) / dist2;
        let scal = yv.data.beta * fy * g * pinhole_we(scene, cos);
        let c = dot3_on(&self.w, &sc.spec[(s - 1) * n..s * n], on) * scal;
        // Without media the transmittance is 0 or 1 (bdpt-allbins refuses media).
        if c == Vec3::ZERO || transmittance(scene, yv.endpoint(), zc.endpoint(), rays).is_zero() {
            return None;
        }
        Some((px, py, c * self.weight(scene, sc, s, 1, Some(&zc))))
    }

    /// s ≥ 1, t ≥ 2: connect z(t−1) to y(s−1) (s = 1: a fresh light point, sampler: four
    /// values); the weighted contribution.
    fn connect(
        &self,
        scene: &Scene,
        sc: &Scratch,
        s: usize,
        t: usize,
        sampler: &mut Sampler,
        rays: &mut u64,
    ) -> Option<Vec3> {
        let n = self.grid.len();
        let z = &sc.camera[t - 1];
        if z.material == NONE || sc.rows_support[t - 1].is_empty() {
            return None;
        }
        if s >= 2
            && sc.rows_support[t - 1]
                .intersect(sc.spec_support[s - 1])
                .is_empty()
        {
            return None;
        }
        let zp = &sc.camera[t - 2];
        let q = &sc.rows[(t - 1) * 3 * n..t * 3 * n];
        let sampled;
        let (yv, ys, ysup, yprev): (&Vertex, &[f32], Support, Option<&Vertex>) = if s == 1 {
            sampled = sample_light_vertex(scene, sampler);
            let l = sampled.light as usize;
            (&sampled, &self.le[l], self.le_support[l], None)
        } else {
            let ys = &sc.spec[(s - 1) * n..s * n];
            (
                &sc.light[s - 1],
                ys,
                sc.spec_support[s - 1],
                sc.light.get(s.wrapping_sub(2)),
            )
        };
        let on = sc.rows_support[t - 1].intersect(ysup);
        if on.is_empty() || (yv.kind == VertexKind::Surface && yv.material == NONE) {
            return None;
        }
        // The connection z → y: lobes at both ends and the geometry term (Veach eq. 8.3).
        let (w, d2) = z.towards(yv);
        let fz = f_dir(scene, z, Some(zp), w);
        let fy = f_dir(scene, yv, yprev, -w);
        let g = z.abs_cos(w) * yv.abs_cos(w) / d2;
        let scal = fz * fy * g * z.data.beta * yv.data.beta;
        if scal == 0.0 {
            return None;
        }
        let c = dot3_on(q, ys, on) * scal;
        // Without media the transmittance is 0 or 1 (bdpt-allbins refuses media).
        if c == Vec3::ZERO || transmittance(scene, z.endpoint(), yv.endpoint(), rays).is_zero() {
            return None;
        }
        Some(c * self.weight(scene, sc, s, t, if s == 1 { Some(yv) } else { None }))
    }
}

impl Integrator for BdptAllbins {
    type Scratch = Scratch;

    fn scratch(&self, _: &Scene) -> Scratch {
        let n = self.grid.len();
        let v = self.max_depth + 2;
        Scratch {
            light: Vec::with_capacity(v),
            camera: Vec::with_capacity(v),
            spec: vec![0.0; v * n],
            rows: vec![0.0; v * 3 * n],
            spec_support: vec![Support::EMPTY; v],
            rows_support: vec![Support::EMPTY; v],
        }
    }

    fn aux_layers(&self) -> Vec<String> {
        if !self.strategy_images {
            return Vec::new();
        }
        strategy_layer_names(self.max_depth)
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
                if segments == 0 || segments > self.max_depth || (s == 1 && t == 1) {
                    continue;
                }
                if self.only.is_some_and(|o| o != (s, t)) {
                    continue;
                }
                // bdpt's strategy-image order: (camera vertices, light vertices)
                let layer = strategy_layer(t, s);
                if t == 1 {
                    let Some((px, py, c)) = self.light_tracing(scene, sc, s, &mut rays) else {
                        continue;
                    };
                    if sink.splat(px, py, c) {
                        if self.strategy_images {
                            let pix = (py as u32).min(sink.height - 1) * sink.width
                                + (px as u32).min(sink.width - 1);
                            sink.aux(layer, pix, c);
                        }
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
