//! Participating media in `bdpt-forward`/`bdpt-backward`: the segments of a connected path, the
//! transmittance of the connecting segment, and the free-flight factors of the estimate and of
//! the MIS weights (docs/design.md §4, "Media in the bidirectional tracers").
//!
//! A sub-path samples each free flight at the wavelength it carries on that segment, with the
//! collision coefficients of its side (camera: column sum, light: row sum; Mojzík eq. 3), and
//! keeps the weight T·ρ/p of the flight. After the reset a segment may carry another wavelength:
//! its weight is then multiplied by T(λ_new)/T(λ_old) ([`retarget`]). Conditioning the geometric
//! pdf on the discarded sub-path wavelength keeps the estimate unbiased (the discarded wavelength
//! is an auxiliary variable whose own pdf cancels). The MIS weights evaluate every strategy's
//! free-flight pdfs at the path's final wavelengths, the same function for every strategy, so
//! they still sum to 1.

use super::geometric::SegmentLog;
use super::mis::{FullPath, SegmentSource};
use super::subpath::Vertex;
use crate::integrator::Sampler;
use crate::medium::Tracking;
use crate::scene::Scene;
use crate::transport::segment::{distance_pdf, distance_to_surface, retarget, towards};
use crate::transport::{Segment, VertexKind, transmittance_lanes};

/// Copy the segments and the media of the camera prefix x0 … x(s−1) and of the light suffix into
/// `path` (whose vertices are set), with an empty connection segment x(s−1) → x_s. The light
/// sub-path's segments are turned around into path order. `fresh`: x_s is a fresh light point.
pub fn gather(
    scene: &Scene,
    path: &mut FullPath,
    cam: &SegmentLog,
    light: &SegmentLog,
    s: usize,
    fresh: bool,
) {
    let k = path.k;
    path.seg.clear();
    path.seg_source.clear();
    path.stretches.clear();
    path.media.clear();
    for i in 0..k {
        let v = &path.v[i];
        let media = if i == 0 {
            [scene.camera_medium; 2]
        } else if i < s {
            cam.segs[i].end_media
        } else {
            let m = k - 1 - i; // index in the light sub-path
            if m == 0 || fresh {
                scene.light_media(v.light as usize)
            } else {
                light.segs[m].end_media
            }
        };
        path.media.push(media);
    }
    for i in 0..k - 1 {
        let first = path.stretches.len() as u32;
        let seg = if i + 1 < s {
            // camera segment x_i → x(i+1), stored at the vertex it reached
            let seg = cam.segs[i + 1];
            path.stretches
                .extend_from_slice(seg.stretches(&cam.stretches));
            path.seg_source.push(SegmentSource::Camera(i as u32 + 1));
            seg
        } else if i + 1 == s || fresh {
            path.seg_source.push(SegmentSource::Connection);
            Segment::default()
        } else {
            // light segment x(i+1) → x_i, stored at light vertex k−2−i + 1
            path.seg_source
                .push(SegmentSource::Light((k - 1 - i) as u32));
            let seg = light.segs[k - 1 - i];
            let st = seg.stretches(&light.stretches);
            path.stretches.extend(st.iter().rev().map(|x| x.reversed()));
            Segment {
                far_end: seg.far_start,
                far_start: seg.far_end,
                ..seg
            }
        };
        let last = path.stretches.len() as u32;
        path.seg.push(Segment { first, last, ..seg });
    }
}

/// The medium that vertex `i` of `path` sends direction `d` into.
#[inline]
fn medium_towards(path: &FullPath, i: usize, d: glam::Vec3) -> u32 {
    let v: &Vertex = &path.v[i];
    match v.kind {
        VertexKind::Medium => v.material,
        VertexKind::Camera => path.media[i][0],
        _ => towards(path.media[i], v.n, d),
    }
}

/// The transmittance of the connecting segment x(s−1) → x_s at λ(s−1) through media and
/// index-matched boundaries (`None`: blocked), recording its stretches and, for aware tracking,
/// the distances past medium end points that its pdfs need.
pub fn connection(
    scene: &Scene,
    path: &mut FullPath,
    s: usize,
    mode: Tracking,
    rays: &mut u64,
    sampler: &mut Sampler,
) -> Option<f32> {
    let (a, b) = (path.v[s - 1], path.v[s]);
    let dir = (b.p - a.p).normalize();
    let first = path.stretches.len();
    let lambda = path.lambda[s - 1];
    let mut u = || sampler.next();
    // Shadow rays start on the surface side: at the light vertex for light tracing.
    let (tr, _) = if s == 1 {
        let m = medium_towards(path, 1, -dir);
        let log = Some(&mut path.stretches);
        let r = transmittance_lanes::<f32>(
            scene,
            b.endpoint(),
            a.endpoint(),
            m,
            lambda,
            1,
            mode,
            rays,
            &mut u,
            log,
        )?;
        let st = &mut path.stretches[first..];
        st.reverse();
        for x in st.iter_mut() {
            *x = x.reversed();
        }
        r
    } else {
        let m = medium_towards(path, s - 1, dir);
        let log = Some(&mut path.stretches);
        transmittance_lanes::<f32>(
            scene,
            a.endpoint(),
            b.endpoint(),
            m,
            lambda,
            1,
            mode,
            rays,
            &mut u,
            log,
        )?
    };
    // Past a medium end, along the stretch that holds it (a medium vertex is always in one).
    let st = &path.stretches[first..];
    let aware = mode == Tracking::Aware;
    let mut far = |v: &Vertex, d: Option<glam::Vec3>| match d {
        Some(d) if aware && v.kind == VertexKind::Medium => {
            distance_to_surface(scene, v.p, d, rays)
        }
        _ => f32::INFINITY,
    };
    let far_end = far(&b, st.last().map(|x| x.d));
    let far_start = far(&a, st.first().map(|x| -x.d));
    path.seg[s - 1] = Segment {
        first: first as u32,
        last: path.stretches.len() as u32,
        lambda,
        far_end,
        far_start,
        ..Segment::default()
    };
    Some(tr)
}

/// The free-flight pdfs of every segment at the path's final wavelengths in both directions
/// (`dist_fwd`, `dist_rev`), for the MIS weights. A sub-path segment's pdfs at a wavelength are
/// computed once per sample and kept in its log (`cam`, `light`): a path of k vertices has about
/// k²/2 connections, each needing the pdfs of its k − 1 segments, and without the memo their
/// exponentials and spectral coefficients took over half of a dense medium's BDPT sample
/// (docs/performance.md §3, "Dense media"). The memo returns the very values computed.
pub fn distance_pdfs(
    scene: &Scene,
    path: &mut FullPath,
    mode: Tracking,
    cam: &SegmentLog,
    light: &SegmentLog,
) {
    for i in 0..path.k - 1 {
        let lambda = path.lambda[i];
        let log = match path.seg_source[i] {
            SegmentSource::Camera(j) => Some((cam, j as usize)),
            SegmentSource::Light(j) => Some((light, j as usize)),
            SegmentSource::Connection => None,
        };
        if let Some((log, j)) = log
            && let Some(Some((bits, fwd, rev))) = log.pdfs.borrow().get(j)
            && *bits == lambda.to_bits()
        {
            (path.dist_fwd[i], path.dist_rev[i]) = (*fwd, *rev);
            continue;
        }
        let seg = path.seg[i];
        let st = seg.stretches(&path.stretches);
        let end = path.v[i + 1].kind == VertexKind::Medium;
        let start = path.v[i].kind == VertexKind::Medium;
        let fwd = distance_pdf(scene, st, false, end, seg.far_end, lambda, false, mode) as f64;
        let rev = distance_pdf(scene, st, true, start, seg.far_start, lambda, true, mode) as f64;
        (path.dist_fwd[i], path.dist_rev[i]) = (fwd, rev);
        if let Some((log, j)) = log {
            let mut memo = log.pdfs.borrow_mut();
            if memo.len() <= j {
                memo.resize(j + 1, None);
            }
            memo[j] = Some((lambda.to_bits(), fwd, rev));
        }
    }
}

/// The product of the sampled segments' free-flight weights T·ρ/p at the path's final
/// wavelengths (every segment but the connection x(s−1) → x_s).
pub fn flight_weight(scene: &Scene, path: &FullPath, s: usize, sampler: &mut Sampler) -> f64 {
    let mut w = 1.0f64;
    let mut u = || sampler.next();
    for i in 0..path.k - 1 {
        if i + 1 == s {
            continue;
        }
        let seg = path.seg[i];
        let st = seg.stretches(&path.stretches);
        w *= seg.w as f64 * retarget(scene, st, seg.lambda, path.lambda[i], &mut u) as f64;
    }
    w
}
