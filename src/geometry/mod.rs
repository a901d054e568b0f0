//! Rays, shapes, the acceleration structure and the camera.

pub mod bvh;
pub mod camera;
pub mod frame;
pub mod ray;
pub mod shapes;

pub use bvh::{AUTO_HIGH_MAX, Accel, BuildQuality, ISA_VAR, Isa, IsaError, Layout};
pub use camera::Camera;
pub use frame::Frame;
pub use ray::{Hit, Ray};
pub use shapes::{Sphere, Triangle};
