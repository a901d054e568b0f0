//! `pt-hero`: hero wavelength spectral sampling (Wilkie et al. 2014) with fluorescent vertices
//! (bispectral HWSS, Mojzík §6.2). It is [`Walk`] with N lanes: the hero wavelength is sampled
//! over the camera range and the other lanes are rotated from it; the hero lane makes every
//! directional decision. The 4-lane hot path runs on glam `Vec4`, other lane counts on
//! [`LaneArr`].

use super::walk::Walk;
use crate::integrator::{Integrator, IntegratorOptions, SampleSink, Sampler};
use crate::scene::Scene;
use crate::spectrum::{LaneArr, MAX_LANES};
use glam::Vec4;

pub struct PtHero {
    walk: Walk,
}

impl PtHero {
    pub fn new(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        if o.lanes == 0 || o.lanes as usize > MAX_LANES {
            return Err(format!("lanes must be 1–{MAX_LANES}, got {}", o.lanes));
        }
        if scene
            .materials
            .iter()
            .any(|m| m.wavelength_dependent_directions())
        {
            return Err(
                "pt-hero assumes wavelength-independent directional sampling (diffuse lobes)"
                    .into(),
            );
        }
        Ok(PtHero {
            walk: Walk::new(scene, o, o.lanes as usize),
        })
    }
}

impl Integrator for PtHero {
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
        if self.walk.lanes == 4 {
            self.walk.trace::<Vec4>(scene, x, y, sampler, sink)
        } else {
            self.walk.trace::<LaneArr>(scene, x, y, sampler, sink)
        }
    }
}
