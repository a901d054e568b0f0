//! Acceleration structure (placeholder; being written).
use super::{Hit, Ray, Sphere, Triangle};
pub struct Accel;
impl Accel {
    pub fn build(_t: &[Triangle], _s: &[Sphere]) -> Accel { Accel }
    pub fn intersect(&self, _r: &Ray, _tmax: f32) -> Option<Hit> { None }
    pub fn occluded(&self, _r: &Ray, _tmax: f32) -> bool { false }
}
