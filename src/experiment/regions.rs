//! Regions of a run: the material or shape each pixel sees (through index-matched medium
//! boundaries), as masks for per-region metrics and as `regions.json` in the run folder.

use super::config::RegionBy;
use super::record::write_text;
use super::setup::Setup;
use crate::error::Error;
use crate::scene::Scene;
use std::path::Path;

/// A named region and its pixels.
pub struct Region {
    pub name: String,
    pub mask: Vec<bool>,
}

/// The regions the config asks for that cover at least one pixel (none without `regions`);
/// writes `regions.json` into `run_dir`.
pub fn masks(s: &Setup, run_dir: &Path) -> Result<Vec<Region>, Error> {
    let Some(r) = &s.cfg.regions else {
        return Ok(Vec::new());
    };
    let (names, ids) = region_ids(&s.scene, r.by);
    let mut regions: Vec<Region> = Vec::new();
    for (i, n) in names.iter().enumerate() {
        let mask: Vec<bool> = ids.iter().map(|&id| id == Some(i as u16)).collect();
        if mask.iter().any(|&b| b) && !regions.iter().any(|g| &g.name == n) {
            regions.push(Region {
                name: n.clone(),
                mask,
            });
        }
    }
    let json = serde_json::json!({
        "by": r.by,
        "names": names,
        "ids": ids.iter().map(|i| i.map(|v| v as i64).unwrap_or(-1)).collect::<Vec<_>>(),
    });
    write_text(&run_dir.join("regions.json"), &json.to_string())?;
    Ok(regions)
}

/// Region of each pixel (index into `names`), from a primary ray through the pixel centre to
/// the first visible surface.
pub fn region_ids(scene: &Scene, by: RegionBy) -> (Vec<String>, Vec<Option<u16>>) {
    let names: Vec<String> = match by {
        RegionBy::Material => scene.material_names.clone(),
        RegionBy::Shape => scene.shapes.iter().map(|s| s.name.clone()).collect(),
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut ids = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let ray = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
            let id = scene.first_visible(&ray).map(|hit| {
                let p = scene.prims[hit.prim as usize];
                match by {
                    RegionBy::Material => p.material as u16,
                    RegionBy::Shape => p.shape as u16,
                }
            });
            ids.push(id.filter(|&i| (i as usize) < names.len()));
        }
    }
    (names, ids)
}
