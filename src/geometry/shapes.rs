//! Primitive shapes: triangles and analytic spheres.

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    pub v: [Vec3; 3],
}

impl Triangle {
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        Triangle { v: [a, b, c] }
    }
    /// Unnormalised geometric normal (cross(v1 - v0, v2 - v0)); its length is twice the area.
    pub fn normal_raw(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
    pub fn area(&self) -> f32 {
        0.5 * self.normal_raw().length()
    }
    /// Point at barycentrics (b1, b2) of v1 and v2.
    pub fn point(&self, b1: f32, b2: f32) -> Vec3 {
        self.v[0] * (1.0 - b1 - b2) + self.v[1] * b1 + self.v[2] * b2
    }
    /// Uniform area sampling from two uniform numbers.
    pub fn sample_uniform(&self, u1: f32, u2: f32) -> Vec3 {
        let su = u1.sqrt();
        self.point(su * (1.0 - u2), su * u2)
    }
}

#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }
}
