//! Regions of a run: the material or shape each pixel sees (through index-matched medium
//! boundaries), as masks for per-region metrics and as `regions.json` in the run folder.

use super::config::{MAX_NAME_BYTES, RegionBy};
use super::record::write_text;
use super::setup::Setup;
use crate::error::Error;
use crate::scene::Scene;
use std::path::Path;

/// The most memory the region masks may take (one byte per pixel and region).
const MAX_MASK_BYTES: usize = 1 << 28;

/// A named region and its pixels.
pub struct Region {
    pub name: String,
    pub mask: Vec<bool>,
}

/// Check, before anything renders, that the masks of the regions visible in the image fit in
/// [`MAX_MASK_BYTES`] (one primary ray per pixel, no sample); [`masks`] would find it only after
/// the reference.
pub fn check(s: &Setup) -> Result<(), Error> {
    let Some(r) = &s.cfg.regions else {
        return Ok(());
    };
    let (names, ids) = region_ids(&s.scene, r.by);
    let seen: std::collections::BTreeSet<u32> = ids.iter().flatten().copied().collect();
    // A region's name becomes part of its figures' file names.
    if let Some(n) = seen
        .iter()
        .map(|&id| &names[id as usize])
        .find(|n| n.len() > MAX_NAME_BYTES)
    {
        let head: String = n.chars().take(20).collect();
        return Err(Error::input(format!(
            "{}: field `regions.by`: the {} name {head:?}… of scene '{}' is {} bytes long; a \
             region's name becomes a file name and may have at most {MAX_NAME_BYTES} bytes",
            s.config_path.display(),
            r.by.noun(),
            s.scene_path.display(),
            n.len()
        )));
    }
    if seen.len().saturating_mul(ids.len()) > MAX_MASK_BYTES {
        return Err(Error::input(format!(
            "{}: field `regions.by`: {} regions are visible in the {} pixels of the image: too \
             many for per-region metrics (their masks would take more than {} MB)",
            s.config_path.display(),
            seen.len(),
            ids.len(),
            MAX_MASK_BYTES >> 20
        )));
    }
    Ok(())
}

/// The regions the config asks for that cover at least one pixel (none without `regions`);
/// writes `regions.json` into `run_dir`.
pub fn masks(s: &Setup, run_dir: &Path) -> Result<Vec<Region>, Error> {
    let Some(r) = &s.cfg.regions else {
        return Ok(Vec::new());
    };
    let (names, ids) = region_ids(&s.scene, r.by);
    // One pass over the pixels (not one per name: a scene may have many thousand shapes), and
    // masks only for the regions that are seen, in the order of `names`.
    let mut seen = std::collections::BTreeMap::<u32, Vec<bool>>::new();
    for (p, id) in ids.iter().enumerate() {
        if let Some(id) = *id {
            if !seen.contains_key(&id) && (seen.len() + 1) * ids.len() > MAX_MASK_BYTES {
                return Err(Error::input(format!(
                    "{}: field `regions.by`: more than {} regions are visible in the {} pixels \
                     of the image: too many for per-region metrics",
                    s.config_path.display(),
                    seen.len(),
                    ids.len()
                )));
            }
            seen.entry(id).or_insert_with(|| vec![false; ids.len()])[p] = true;
        }
    }
    let mut regions: Vec<Region> = Vec::new();
    for (id, mask) in seen {
        let n = &names[id as usize];
        if !regions.iter().any(|g| &g.name == n) {
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
pub fn region_ids(scene: &Scene, by: RegionBy) -> (Vec<String>, Vec<Option<u32>>) {
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
                    RegionBy::Material => p.material,
                    RegionBy::Shape => p.shape,
                }
            });
            ids.push(id.filter(|&i| (i as usize) < names.len()));
        }
    }
    (names, ids)
}
