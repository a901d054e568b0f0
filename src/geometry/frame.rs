//! Orthonormal shading frames and cosine-weighted hemisphere sampling.

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Build a frame around unit normal `n` (Duff et al. 2017, branchless ONB).
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method); pdf = cos/π.
pub fn sample_cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u2;
    let (s, c) = phi.sin_cos();
    Vec3::new(r * c, r * s, (1.0 - u1).max(0.0).sqrt())
}

/// The unit direction with cos θ = `cos_theta` about +z and azimuth `phi`.
#[inline]
pub fn spherical_direction(cos_theta: f32, phi: f32) -> Vec3 {
    let r = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), cos_theta)
}

/// ∫ f(ω) dω over the unit sphere by the midpoint rule on an `m` × `m` grid in (cos θ, φ), for
/// tests of pdfs.
#[cfg(test)]
pub fn integrate_over_sphere(m: usize, f: impl Fn(Vec3) -> f64) -> f64 {
    let mut s = 0.0f64;
    for i in 0..m {
        let z = -1.0 + 2.0 * (i as f32 + 0.5) / m as f32;
        for k in 0..m {
            let phi = 2.0 * std::f32::consts::PI * (k as f32 + 0.5) / m as f32;
            s += f(spherical_direction(z, phi));
        }
    }
    s * 4.0 * std::f64::consts::PI / (m * m) as f64
}
