//! The factors of the measurement contribution f_j (eq. 6.2) that a sub-path fixes by itself,
//! computed once per sub-path instead of once per connection (`evaluate::measurement_cached`),
//! and the spectral factors f_λ of the materials at the wavelengths last seen.
//!
//! A segment between two vertices of the same sub-path keeps its direction, squared distance
//! and geometry factor |cos|·|cos'|/d² in every connection; a vertex whose two path neighbours
//! both lie on its sub-path keeps its directional factor f_dir. The spectral factor f_λ depends
//! only on the material (or medium) and on (λ_i, λ(i−1), shift), so it is kept per material with
//! the exact wavelengths it was evaluated at and reused only for those; the sub-path walks fill
//! it too (their diagonal is f_λ of a vertex that keeps the wavelength). Every cached value is
//! computed by the same expression, in the same order, as the uncached `evaluate::measurement`,
//! so the products are bit-identical.

use super::connection::{Seg, camera_term};
use super::wavelength::LambdaKey;
use crate::material::Bbrrdf;
use crate::scene::{NONE, Scene};
use crate::transport::spectral::with_spectrum;
use crate::transport::{Vertex, VertexKind};

/// f_λ of one material at the wavelengths it was last evaluated at.
#[derive(Clone, Copy, Debug, Default)]
struct Spectral {
    /// λ_i and λ(i−1) (`LambdaKey::pair`).
    key: u64,
    /// 0: empty, 1: no shift, 2: shift.
    tag: u8,
    f: f32,
}

impl Spectral {
    #[inline(always)]
    fn key(lambda_in: f32, lambda_out: f32, shift: bool) -> (u64, u8) {
        (LambdaKey::pair(lambda_in, lambda_out), 1 + shift as u8)
    }
}

/// The connection-independent factors of one sub-path, indexed like the sub-path.
#[derive(Clone, Debug, Default)]
pub struct SubpathCache {
    /// `seg[i]`: the segment leaving vertex i in path order (camera sub-path: towards vertex
    /// i + 1; light sub-path: towards vertex i − 1, so `seg[0]` is unused there).
    seg: Vec<Seg>,
    /// `dir[i]`: f_dir at vertex i between its two sub-path neighbours (0 at the ends).
    dir: Vec<f32>,
    /// Camera sub-path: the camera's end of the measurement, W_e(x0 → x1) times the geometry
    /// factor without the pinhole's cosine (`connection::camera_term`; 0 behind the camera).
    pub head: f64,
    /// Built for the current sub-path (they are built on first use: many samples' connections
    /// end before an interior vertex).
    ready: bool,
}

impl SubpathCache {
    fn clear(&mut self, n: usize) {
        self.seg.clear();
        self.dir.clear();
        self.dir.resize(n, 0.0);
        self.head = 0.0;
        self.ready = true;
    }

    /// Forget the sub-path (a new one was traced).
    #[inline]
    pub fn invalidate(&mut self) {
        self.ready = false;
    }

    /// Build for the camera sub-path x0 … x(n−1), unless built.
    #[inline]
    pub fn camera<P>(&mut self, scene: &Scene, v: &[Vertex<P>]) {
        if !self.ready {
            self.build_camera(scene, v);
        }
    }

    /// Build for the light sub-path y0 … y(n−1), unless built.
    #[inline]
    pub fn light<P>(&mut self, scene: &Scene, v: &[Vertex<P>]) {
        if !self.ready {
            self.build_light(scene, v);
        }
    }

    fn build_camera<P>(&mut self, scene: &Scene, v: &[Vertex<P>]) {
        let n = v.len();
        self.clear(n);
        self.seg
            .extend(v.windows(2).map(|p| Seg::new(&p[0], &p[1])));
        // vertex i + 1 between segments i and i + 1
        for (i, p) in v.windows(3).enumerate() {
            let (wo, wi) = (-self.seg[i].w, self.seg[i + 1].w);
            self.dir[i + 1] = p[1].scattering(scene).eval(wo, wi);
        }
        if n >= 2 {
            let Seg { w, d2, .. } = self.seg[0];
            self.head = camera_term(scene, w, d2, &v[1]);
        }
    }

    /// The light sub-path y0 … y(n−1) (y0 on the light), whose path order is reversed.
    fn build_light<P>(&mut self, scene: &Scene, v: &[Vertex<P>]) {
        let n = v.len();
        self.clear(n);
        self.seg.push(Seg::default());
        self.seg
            .extend(v.windows(2).map(|p| Seg::new(&p[1], &p[0])));
        // vertex j = i + 1, reached along segment j + 1 and left along segment j in path order
        for (i, p) in v.windows(3).enumerate() {
            let (wo, wi) = (-self.seg[i + 2].w, self.seg[i + 1].w);
            self.dir[i + 1] = p[1].scattering(scene).eval(wo, wi);
        }
    }

    #[inline]
    pub fn seg(&self, i: usize) -> Seg {
        self.seg[i]
    }

    #[inline]
    pub fn dir(&self, i: usize) -> f32 {
        self.dir[i]
    }
}

/// f_λ of every material and medium of the scene at the wavelengths it was last evaluated at
/// (per thread; a pure function of the material and the wavelengths, so never stale).
#[derive(Clone, Debug, Default)]
pub struct SpectralCache {
    /// Materials first, then media.
    slots: Vec<Spectral>,
    materials: usize,
}

impl SpectralCache {
    pub fn new(scene: &Scene) -> Self {
        let materials = scene.materials.len();
        SpectralCache {
            slots: vec![Spectral::default(); materials + scene.media.len()],
            materials,
        }
    }

    /// The slot of the spectral part of `x` (as `with_spectrum!` finds it), `None` if it has none.
    #[inline]
    fn slot<P>(&self, x: &Vertex<P>) -> Option<usize> {
        match x.kind {
            VertexKind::Surface if x.material != NONE => Some(x.material as usize),
            VertexKind::Medium => Some(self.materials + x.material as usize),
            _ => None,
        }
    }

    /// f_λ(λ_i = `li`, λ(i−1) = `lo`, `shift`) of vertex `x`, `eval` on a miss; `None` if the
    /// vertex has no spectral part.
    #[inline(always)]
    fn get<P>(
        &mut self,
        x: &Vertex<P>,
        lambda_in: f32,
        lambda_out: f32,
        shift: bool,
        eval: impl FnOnce() -> Option<f32>,
    ) -> Option<f32> {
        let (key, tag) = Spectral::key(lambda_in, lambda_out, shift);
        let slot = self.slot(x)?;
        let c = &mut self.slots[slot];
        if c.key == key && c.tag == tag {
            return Some(c.f);
        }
        let f = eval()?;
        *c = Spectral { key, tag, f };
        Some(f)
    }

    /// f_λ of interior vertex `x` at (λ_i, λ(i−1), shift) (eq. 6.2); `None` if it has no
    /// spectral part.
    #[inline]
    pub fn f_lambda<P>(
        &mut self,
        scene: &Scene,
        x: &Vertex<P>,
        lambda_in: f32,
        lambda_out: f32,
        shift: bool,
    ) -> Option<f32> {
        self.get(x, lambda_in, lambda_out, shift, || {
            Some(with_spectrum!(scene, x, m => m.eval(lambda_in, lambda_out, shift), else return None))
        })
    }

    /// The diagonal of `m`, the spectral part of `x`, at `lambda`: f_λ(λ, λ, no shift), since
    /// `Bbrrdf::eval` of a non-shifting pair is the diagonal.
    #[inline]
    pub fn diagonal<P>(&mut self, x: &Vertex<P>, m: &impl Bbrrdf, lambda: f32) -> f32 {
        match self.get(x, lambda, lambda, false, || Some(m.diagonal(lambda))) {
            Some(f) => f,
            None => m.diagonal(lambda),
        }
    }
}

/// The wavelength pdfs [p_c, P_c, p_l, P_l] of each sub-path vertex (eqs. 6.6–6.8) at the
/// wavelength pair and shift they were last evaluated at, for `evaluate::fill_pdfs`: a path of
/// k vertices has about k²/2 connections, each needing the pdfs of its k − 2 interior vertices,
/// and a vertex's pdfs depend only on its material or medium and on (λ_i, λ(i−1), shift). The
/// memo returns the very values computed.
#[derive(Clone, Debug, Default)]
pub struct VertexPdfMemo {
    cam: Vec<Option<(u64, bool, [f64; 4])>>,
    light: Vec<Option<(u64, bool, [f64; 4])>>,
}

impl VertexPdfMemo {
    /// Forget both sub-paths (new ones were traced).
    #[inline]
    pub fn invalidate(&mut self) {
        self.cam.clear();
        self.light.clear();
    }

    /// The pdfs of vertex `j` of the camera (or `light`) sub-path at (`lambda_in`,
    /// `lambda_out`, `shifted`): remembered, or `eval()` (whose `None` is not remembered).
    #[inline]
    pub fn get(
        &mut self,
        light: bool,
        j: usize,
        (lambda_in, lambda_out, shifted): (f32, f32, bool),
        eval: impl FnOnce() -> Option<[f64; 4]>,
    ) -> Option<[f64; 4]> {
        let memo = if light {
            &mut self.light
        } else {
            &mut self.cam
        };
        let key = LambdaKey::pair(lambda_in, lambda_out);
        if let Some(Some((k, sh, p))) = memo.get(j)
            && *k == key
            && *sh == shifted
        {
            return Some(*p);
        }
        let p = eval()?;
        if memo.len() <= j {
            memo.resize(j + 1, None);
        }
        memo[j] = Some((key, shifted, p));
        Some(p)
    }
}
