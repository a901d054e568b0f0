//! `pt-mono`: one wavelength per camera path, next-event estimation with MIS. At a fluorescent
//! vertex the incident wavelength is sampled as a camera path does (Jung 5.3: decide with P_c,
//! then sample the absorption spectrum); that wavelength drives both the light sample at the
//! vertex and the continuation. It is [`Walk`] with one lane.

use super::walk::Walk;
use crate::integrator::{Integrator, IntegratorOptions, SampleSink, Sampler};
use crate::scene::Scene;

pub struct PtMono {
    walk: Walk,
}

impl PtMono {
    pub fn new(scene: &Scene, o: &IntegratorOptions) -> Result<Self, String> {
        Ok(PtMono {
            walk: Walk::new(scene, o, 1),
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
        self.walk.trace::<f32>(scene, x, y, sampler, sink)
    }
}
