//! `stokes inspect`: what a scene contains after validation.

use super::{load_scene, sensor_label};
use crate::Error;
use crate::io::text::show_path;
use std::path::Path;

/// `stokes inspect`: print the scene's domain, camera, primitives, acceleration structure,
/// materials, media and lights.
pub fn inspect(path: &Path) -> Result<(), Error> {
    let s = load_scene(path, false)?;
    // Names come from the scene file: their control bytes are escaped, never sent to the
    // terminal.
    let esc = |n: &str| crate::io::text::escape_control(n, false);
    println!("scene: {}", show_path(path));
    println!(
        "domain: [{}, {}] nm, camera range [{}, {}] nm",
        s.domain.min, s.domain.max, s.observer.range.min, s.observer.range.max
    );
    println!(
        "camera: {}×{}, sensor {}",
        s.camera.width,
        s.camera.height,
        sensor_label(&s)
    );
    println!(
        "primitives: {} triangles, {} spheres",
        s.triangles.len(),
        s.spheres.len()
    );
    let (nodes, packets, _, bytes) = s.accel.layout();
    let quality = match s.accel.quality() {
        Some((crate::geometry::BuildQuality::Auto, q)) => format!("auto → {}", q.name()),
        Some((q, _)) => q.name().to_string(),
        None => "custom".to_string(),
    };
    println!(
        "acceleration: BVH8 of quality {quality}, built in {:.3} s: {nodes} nodes ({}), {packets} \
         leaf packets, {:.2} MB{}",
        s.accel.build_seconds(),
        s.accel.node_layout(),
        bytes as f64 / 1e6,
        if s.accel.is_flat() {
            "; traced as one flat loop over the primitives"
        } else {
            ""
        }
    );
    println!("{}", isa_line(s.accel.isa()));
    for (n, m) in s.material_names.iter().zip(&s.materials) {
        use crate::material::Bbrrdf;
        let kind = match m {
            crate::material::Material::Lambert(_) => "lambert".to_string(),
            #[cfg(feature = "fluorescence")]
            crate::material::Material::Fluorescent(_) => "fluorescent-diffuse".to_string(),
            #[cfg(feature = "fluorescence")]
            crate::material::Material::Reradiation(r) => {
                let (o, i) = r.shape();
                let sampled = match r.sampler() {
                    Some(s) => format!(
                        ", shifts drawn from {} Gaussians (tables' share {})",
                        s.components(),
                        s.defensive()
                    ),
                    None => String::new(),
                };
                format!(
                    "reradiation, {o}×{i} matrix{sampled}, {} bytes to render",
                    r.render_bytes()
                )
            }
            #[cfg(feature = "fluorescence")]
            crate::material::Material::ReradiationGmm(g) => format!(
                "reradiation-gmm, {} Gaussians, model {} bytes, {} bytes to render",
                g.components(),
                g.model_bytes(),
                g.render_bytes()
            ),
        };
        println!(
            "material {}: {kind}, {}",
            esc(n),
            if m.is_fluorescent() {
                "fluorescent"
            } else {
                "non-fluorescent"
            }
        );
    }
    for (n, m) in s.medium_names.iter().zip(&s.media) {
        use crate::medium::Density;
        let density = match &m.density {
            Density::Homogeneous => "homogeneous".to_string(),
            Density::Grid(g) => format!(
                "grid {}×{}×{}, density scale {}, max density {}",
                g.grid.res[0],
                g.grid.res[1],
                g.grid.res[2],
                g.scale,
                g.grid.max_density() * g.scale
            ),
        };
        let fl = if m.coefficients.is_fluorescent() {
            "fluorescent"
        } else {
            "non-fluorescent"
        };
        println!("medium {}: {density}, {fl}, phase g = {}", esc(n), m.g);
    }
    if s.camera_medium != crate::scene::NONE {
        println!(
            "camera in medium {}",
            esc(&s.medium_names[s.camera_medium as usize])
        );
    }
    for l in &s.lights {
        println!(
            "light {}: area {:.4}, power {:.4}{}",
            esc(&l.name),
            l.area,
            l.power,
            if l.two_sided { ", two-sided" } else { "" }
        );
    }
    Ok(())
}

/// The instruction set rays are traced with, whether `STOKES_ISA` chose it, and what the CPU
/// has.
pub(super) fn isa_line(isa: crate::geometry::Isa) -> String {
    use crate::geometry::{ISA_VAR, Isa};
    let forced = std::env::var(ISA_VAR).is_ok_and(|v| !v.trim().is_empty());
    let available: Vec<_> = Isa::available().iter().map(|i| i.name()).collect();
    format!(
        "instruction set: {isa}{} (this CPU: {})",
        if forced {
            format!(", forced by {ISA_VAR}")
        } else {
            String::new()
        },
        available.join(", ")
    )
}
