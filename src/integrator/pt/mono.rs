//! `pt-mono`: one wavelength per camera path, next-event estimation with MIS. At a fluorescent
//! vertex the incident wavelength is sampled as a camera path does (Jung 5.3: decide with P_c,
//! then sample the absorption spectrum); that wavelength drives both the light sample at the
//! vertex and the continuation.

use super::{light_pdf_solid, sample_diffuse, sample_light_connection};
use crate::integrator::{Integrator, IntegratorOptions, MisHeuristic, SampleSink, Sampler};
use crate::material::{Bbrrdf, Material, WavelengthSampling};
use crate::scene::{NONE, Scene};
use crate::spectrum::cie::CameraWavelengths;

pub struct PtMono {
    max_depth: u32,
    camera_wavelengths: CameraWavelengths,
    wavelength_sampling: WavelengthSampling,
    mis: MisHeuristic,
    rr_depth: Option<u32>,
}

impl PtMono {
    pub fn new(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        if scene.has_media {
            return Err("pt-mono does not support participating media yet".into());
        }
        Ok(PtMono {
            max_depth: o.max_depth,
            camera_wavelengths: o.camera_wavelengths,
            wavelength_sampling: o.wavelength_sampling,
            mis: o.mis,
            rr_depth: o.rr_depth,
        })
    }
}

impl Integrator for PtMono {
    type Scratch = ();
    fn scratch(&self, _: &Scene) {}

    fn sample(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        sampler: &mut Sampler,
        _: &mut (),
        sink: &mut SampleSink,
    ) {
        let (lambda_cam, pdf_cam) = scene
            .observer
            .sample_wavelength(self.camera_wavelengths, sampler.next());
        let to_xyz = scene.observer.xyz_weight(lambda_cam) / pdf_cam;
        let mut ray = scene.camera.generate_ray(x, y);
        // Throughput (spectral factors and pdfs) and the wavelength on the current segment.
        let mut beta = 1.0f32;
        let mut lambda = lambda_cam;
        let mut pdf_dir_prev = 0.0f32;
        let mut prev_p = ray.o;
        let mut radiance = 0.0f32;
        let fluorescent = scene.has_fluorescence;
        for depth in 0..self.max_depth {
            sink.stats.rays += 1;
            let Some(it) = scene.intersect(&ray, f32::INFINITY) else {
                break;
            };
            let wo = -ray.d;
            let segments = depth as usize + 1;
            // Emitter hit by the camera ray or a BSDF-sampled ray (MIS against NEE).
            if it.light != NONE {
                let light = &scene.lights[it.light as usize];
                let le = light.le(lambda, it.n, wo);
                if le > 0.0 {
                    let w = if depth == 0 {
                        1.0
                    } else {
                        self.mis
                            .weight2(pdf_dir_prev, light_pdf_solid(scene, prev_p, &it))
                    };
                    let c = beta * le * w;
                    if c > 0.0 {
                        radiance += c;
                        sink.stats.contribution(segments);
                    }
                }
            }
            if it.material == NONE || segments >= self.max_depth as usize {
                break;
            }
            let m: &Material = &scene.materials[it.material as usize];
            // Wavelength at this vertex: λout = `lambda` is known, sample λin (Jung 5.3).
            let lambda_in = if fluorescent && m.is_fluorescent() {
                let s =
                    m.sample_wavelength_camera(lambda, sampler.next2(), self.wavelength_sampling);
                beta *= s.weight;
                s.lambda
            } else {
                beta *= m.diagonal(lambda);
                lambda
            };
            if beta <= 0.0 {
                break;
            }
            // Next-event estimation at λin.
            if let Some(c) = sample_light_connection(scene, &it, wo, sampler, sink.stats) {
                let light = &scene.lights[c.light];
                let le = light.spectrum.eval(lambda_in);
                if le > 0.0 {
                    let pdf_bsdf = c.cos_surface * Material::DIFFUSE;
                    let w = self.mis.weight2(c.pdf_solid, pdf_bsdf);
                    let contrib = beta * Material::DIFFUSE * c.cos_surface * le / c.pdf_solid * w;
                    if contrib > 0.0 {
                        radiance += contrib;
                        sink.stats.contribution(segments + 1);
                    }
                }
            }
            // Continue: cosine sampling, f·cos/pdf = 1 for the diffuse lobe.
            let (next, _wi, pdf) = sample_diffuse(&it, wo, sampler.next2());
            pdf_dir_prev = pdf;
            prev_p = it.p;
            ray = next;
            lambda = lambda_in;
            if let Some(rr) = self.rr_depth
                && depth + 1 >= rr
            {
                let q = beta.min(0.95);
                if sampler.next() >= q {
                    break;
                }
                beta /= q;
            }
        }
        sink.add(to_xyz * radiance);
    }
}
