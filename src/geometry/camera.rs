//! Pinhole camera: look-at, field of view along x or y, resolution.

use super::Ray;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Camera {
    pub origin: Vec3,
    /// Camera basis: right, up, forward (unit vectors).
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub width: u32,
    pub height: u32,
    /// Half extents of the image plane at distance 1.
    pub tan_half_x: f32,
    pub tan_half_y: f32,
}

impl Camera {
    /// `fov_deg` is the full field of view along `fov_axis_x ? x : y`.
    pub fn look_at(
        origin: Vec3,
        target: Vec3,
        up: Vec3,
        fov_deg: f32,
        fov_axis_x: bool,
        width: u32,
        height: u32,
    ) -> Self {
        let forward = (target - origin).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let aspect = width as f32 / height as f32;
        let t = (0.5 * fov_deg.to_radians()).tan();
        let (tan_half_x, tan_half_y) = if fov_axis_x {
            (t, t / aspect)
        } else {
            (t * aspect, t)
        };
        Camera {
            origin,
            right,
            up,
            forward,
            width,
            height,
            tan_half_x,
            tan_half_y,
        }
    }

    /// Ray through film position (x, y) in pixels; (0, 0) is the top-left corner.
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_x;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_y;
        let d = (self.forward + self.right * sx + self.up * sy).normalize();
        Ray::new(self.origin, d)
    }

    /// Area of the image plane at unit distance.
    pub fn film_area(&self) -> f32 {
        4.0 * self.tan_half_x * self.tan_half_y
    }

    /// The pinhole importance W_e = 1 / (A cos⁴θ) of a direction at `cos` = cos θ to the axis,
    /// for the whole film at unit distance (pbrt-v4 `PerspectiveCamera::We` with a box filter,
    /// divided by the pixel count): a camera strategy's pixel sample and a light-tracing splat
    /// then both estimate the pixel's mean radiance (Jung eq. 6.2). The one place it is written.
    #[inline]
    pub fn importance(&self, cos: f64) -> f64 {
        let c2 = cos * cos;
        1.0 / (self.film_area() as f64 * c2 * c2)
    }

    /// The film position in pixels at which direction `d` from the pinhole lands, and cos θ to
    /// the axis; `None` if `d` is outside the image.
    #[inline(always)]
    pub fn project(&self, d: Vec3) -> Option<(f32, f32, f32)> {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        let p = d / cos;
        let sx = p.dot(self.right) / self.tan_half_x;
        let sy = p.dot(self.up) / self.tan_half_y;
        if !(-1.0..1.0).contains(&sx) || !(-1.0..1.0).contains(&sy) {
            return None;
        }
        let x = (sx + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy) * 0.5 * self.height as f32;
        Some((x, y, cos))
    }

    /// Solid-angle pdf of sampling direction `d` when a pixel-uniform position over the whole
    /// film is chosen: 1 / (A cos³θ).
    pub fn pdf_dir(&self, cos: f32) -> f32 {
        1.0 / (self.film_area() * cos * cos * cos)
    }

    /// [`Camera::pdf_dir`] of the unit direction `w` from the pinhole whose axis is `n`; `None`
    /// where `w` is behind the pinhole or off the film (pbrt `Camera::PDF_We`).
    #[inline]
    pub fn pdf_dir_towards(&self, n: Vec3, w: Vec3) -> Option<f32> {
        let cos = w.dot(n);
        if cos <= 0.0 || self.project(w).is_none() {
            return None;
        }
        Some(self.pdf_dir(cos))
    }
}
