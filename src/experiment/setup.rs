//! The first step of a run: the config (scaled down for `--quick`), its scene at the run's
//! resolution, the crop and scanline in the run's pixels, the budgets per mode, and the check
//! that every integrator named accepts the scene.

use super::config::{BudgetMode, Config, Crop, Scanline};
use super::record::ModeBudgets;
use crate::error::Error;
use crate::integrator::{Cancel, IntegratorKind, IntegratorOptions, with_threads};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// Where a run's config comes from: a file, or JSON text given in place of the file at `path`
/// (which names it in errors and resolves its relative paths); and the flag that stops it.
#[derive(Clone, Debug)]
pub struct Source<'a> {
    pub path: &'a Path,
    pub text: Option<&'a str>,
    pub cancel: Option<Cancel>,
}

impl<'a> Source<'a> {
    /// The config file at `path`.
    pub fn file(path: &'a Path) -> Self {
        Source {
            path,
            text: None,
            cancel: None,
        }
    }
}

/// A loaded experiment, ready to run.
pub struct Setup {
    pub cfg: Config,
    pub config_path: PathBuf,
    pub quick: bool,
    /// Results root: runs go to `<root>/<name>/runs/`, cached references to `<root>/references/`.
    pub root: PathBuf,
    pub scene_path: PathBuf,
    /// The scene file's text (reference cache key, parameter-grid overrides).
    pub scene_text: String,
    /// The scene, its camera resized to `width`×`height`.
    pub scene: Scene,
    /// Per variant, its own scene (`variants[i].scene`) at the same resolution, if it has one.
    pub variant_scenes: Vec<Option<Scene>>,
    /// The scene's own resolution.
    pub full_width: u32,
    pub full_height: u32,
    /// The run's resolution (smaller under `--quick`).
    pub width: u32,
    pub height: u32,
    /// Crop and scanline in the run's pixels.
    pub crop: Option<Crop>,
    pub scanline: Option<Scanline>,
    /// Budgets per mode, in snapshot order.
    pub modes: Vec<ModeBudgets>,
    /// Stops every render of the run when set (the Python API's Ctrl-C).
    pub cancel: Option<Cancel>,
}

impl Setup {
    /// Load and check the config in `config_path` and its scene; `root` defaults to `results`
    /// (`results/quick` with `quick`).
    pub fn load(config_path: &Path, root: Option<&Path>, quick: bool) -> Result<Setup, Error> {
        Self::load_from(&Source::file(config_path), root, quick)
    }

    /// [`Setup::load`] of a config file or of a config's text ([`Source`]).
    pub fn load_from(src: &Source, root: Option<&Path>, quick: bool) -> Result<Setup, Error> {
        let config_path = src.path;
        let mut cfg = match src.text {
            Some(t) => Config::from_text(config_path, t)?,
            None => Config::load(config_path)?,
        };
        if quick {
            cfg.quicken();
        }
        // Quick runs default to their own root so they never become a full run's `latest`.
        let root = root.map(Path::to_path_buf).unwrap_or_else(|| {
            if quick {
                "results/quick".into()
            } else {
                "results".into()
            }
        });
        let scene_path = cfg.scene_path(config_path);
        let scene_text = crate::io::input::read_text(&scene_path, crate::io::input::SCENE)
            .map_err(|e| Error::input(format!("{}: field `scene`: {e}", config_path.display())))?;
        // the BVH build on the config's `threads`, as the renders
        let mut scene = with_threads(cfg.threads, || Scene::from_str(&scene_path, &scene_text))
            .map_err(Error::runtime)??;
        let (fw, fh) = (scene.camera.width, scene.camera.height);
        let (w, h) = if quick { quick_size(fw, fh) } else { (fw, fh) };
        resize_camera(&mut scene, w, h);
        let variant_scenes = (0..cfg.variants.len())
            .map(|i| {
                let Some(p) = cfg.variant_scene_path(config_path, i) else {
                    return Ok(None);
                };
                let mut vs = load_variant_scene(config_path, i, &p, (fw, fh), cfg.threads)?;
                resize_camera(&mut vs, w, h);
                Ok(Some(vs))
            })
            .collect::<Result<Vec<_>, Error>>()?;
        let mut s = Setup {
            modes: mode_budgets(&cfg),
            cfg,
            config_path: config_path.to_path_buf(),
            quick,
            root,
            scene_path,
            scene_text,
            scene,
            variant_scenes,
            full_width: fw,
            full_height: fh,
            width: w,
            height: h,
            crop: None,
            scanline: None,
            cancel: src.cancel.clone(),
        };
        s.crop = s.scaled_crop()?;
        s.scanline = s.scaled_scanline()?;
        Ok(s)
    }

    /// Check, before anything renders, that the results root takes the run folder and (when a
    /// reference is rendered) the reference cache: create both folders and a probe file in each.
    /// What the run will write there (`<name>/runs/`, `<name>/latest`, `references/`) must not
    /// be or pass through a link, a FIFO or a device (docs/hardening.md).
    pub fn check_writable(&self) -> Result<(), Error> {
        let name = Path::new(&self.cfg.name);
        let mut dirs = vec![name.join("runs")];
        if self
            .cfg
            .reference
            .as_ref()
            .is_some_and(|r| r.integrator.is_some())
        {
            dirs.push("references".into());
        }
        let bad = |e: String| {
            Error::input(format!(
                "results folder (--out) '{}': {e}",
                crate::io::text::show_path(&self.root)
            ))
        };
        crate::io::tree::check_below(&self.root, &name.join("latest")).map_err(bad)?;
        for rel in dirs {
            let d = self.root.join(&rel);
            crate::io::tree::check_below(&self.root, &rel)
                .and_then(|()| {
                    std::fs::create_dir_all(&d)
                        .map_err(|e| format!("cannot create '{}': {e}", d.display()))
                })
                .and_then(|()| crate::io::output::check_folder(&d))
                .map_err(bad)?;
        }
        Ok(())
    }

    /// Run-to-full-resolution scale factors (x, y).
    fn scale(&self) -> (f64, f64) {
        (
            self.width as f64 / self.full_width as f64,
            self.height as f64 / self.full_height as f64,
        )
    }

    /// The config's crop (in full-resolution pixels) in the run's pixels.
    fn scaled_crop(&self) -> Result<Option<Crop>, Error> {
        let Some(c) = self.cfg.crop else {
            return Ok(None);
        };
        let (fw, fh, w, h) = (self.full_width, self.full_height, self.width, self.height);
        // In u64: a crop `x` near u32::MAX must not wrap round the bounds check.
        if c.x as u64 + c.w as u64 > fw as u64 || c.y as u64 + c.h as u64 > fh as u64 {
            return Err(Error::input(format!(
                "{}: field `crop`: {}×{} at ({}, {}) exceeds the {fw}×{fh} image",
                self.config_path.display(),
                c.w,
                c.h,
                c.x,
                c.y
            )));
        }
        let (sx, sy) = self.scale();
        let x = ((c.x as f64 * sx) as u32).min(w - 1);
        let y = ((c.y as f64 * sy) as u32).min(h - 1);
        Ok(Some(Crop {
            x,
            y,
            w: ((c.w as f64 * sx).round() as u32).clamp(1, w - x),
            h: ((c.h as f64 * sy).round() as u32).clamp(1, h - y),
        }))
    }

    /// The config's scanline (in full-resolution pixels) in the run's pixels.
    fn scaled_scanline(&self) -> Result<Option<Scanline>, Error> {
        let Some(s) = self.cfg.scanline else {
            return Ok(None);
        };
        let (fw, fh, w, h) = (self.full_width, self.full_height, self.width, self.height);
        if s.row.is_some_and(|r| r >= fh) || s.column.is_some_and(|c| c >= fw) {
            return Err(Error::input(format!(
                "{}: field `scanline`: outside the {fw}×{fh} image",
                self.config_path.display()
            )));
        }
        let (sx, sy) = self.scale();
        Ok(Some(Scanline {
            row: s.row.map(|r| ((r as f64 * sy) as u32).min(h - 1)),
            column: s.column.map(|c| ((c as f64 * sx) as u32).min(w - 1)),
        }))
    }

    /// Fail before rendering, naming the variant and integrator, when an integrator of a
    /// variant or of the reference does not accept the scene or its options.
    pub fn check_integrators(&self) -> Result<(), Error> {
        for (i, v) in self.cfg.variants.iter().enumerate() {
            let what = format!("variant `{}`", v.name);
            check(self.variant_scene(i), v.integrator, &v.options, &what)?;
        }
        if let Some(r) = &self.cfg.reference
            && let Some(k) = r.integrator
        {
            check(&self.scene, k, &r.options, "reference")?;
        }
        Ok(())
    }

    /// The scene variant `i` renders: its own (`variants[i].scene`) or the config's.
    pub fn variant_scene(&self, i: usize) -> &Scene {
        self.variant_scenes
            .get(i)
            .and_then(Option::as_ref)
            .unwrap_or(&self.scene)
    }

    /// This run with another config and scene (a sweep value's): the same config file, results
    /// root, resolution, crop, scanline and budgets. Variants render `scene` (the config check
    /// rejects a variant's own scene together with a sweep).
    pub fn with_scene(&self, cfg: Config, scene_text: String, mut scene: Scene) -> Setup {
        resize_camera(&mut scene, self.width, self.height);
        Setup {
            variant_scenes: cfg.variants.iter().map(|_| None).collect(),
            cfg,
            config_path: self.config_path.clone(),
            quick: self.quick,
            root: self.root.clone(),
            scene_path: self.scene_path.clone(),
            scene_text,
            scene,
            full_width: self.full_width,
            full_height: self.full_height,
            width: self.width,
            height: self.height,
            crop: self.crop,
            scanline: self.scanline,
            modes: self.modes.clone(),
            cancel: self.cancel.clone(),
        }
    }

    /// Give `scene` (e.g. a parameter-grid variant of this one) the run's resolution.
    pub fn resize(&self, scene: &mut Scene) {
        resize_camera(scene, self.width, self.height);
    }
}

fn check(
    scene: &Scene,
    kind: IntegratorKind,
    opts: &IntegratorOptions,
    what: &str,
) -> Result<(), Error> {
    crate::integrator::render::check(scene, kind, opts)
        .map_err(|e| Error::input(format!("{what}: integrator `{}`: {e}", kind.name())))
}

/// Load variant `i`'s own scene `path` and check that it renders at the config scene's
/// resolution `full`; errors name the config file and `variants[i].scene`.
fn load_variant_scene(
    config_path: &Path,
    i: usize,
    path: &Path,
    full: (u32, u32),
    threads: Option<usize>,
) -> Result<Scene, Error> {
    let field = |m: String| {
        Error::input(format!(
            "{}: field `variants[{i}].scene`: {m}",
            config_path.display()
        ))
    };
    let text = crate::io::input::read_text(path, crate::io::input::SCENE).map_err(field)?;
    let scene = with_threads(threads, || Scene::from_str(path, &text))
        .map_err(Error::runtime)?
        .map_err(|e| field(format!("the scene is not valid: {e}")))?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    if (w, h) != full {
        return Err(field(format!(
            "'{}' renders {w}×{h}, the config's scene {}×{}: a variant's scene must have the same resolution",
            path.display(),
            full.0,
            full.1
        )));
    }
    Ok(scene)
}

fn resize_camera(scene: &mut Scene, w: u32, h: u32) {
    scene.camera.width = w;
    scene.camera.height = h;
}

/// Resolution used by `--quick`: at most 64×48, keeping the aspect ratio.
pub fn quick_size(w: u32, h: u32) -> (u32, u32) {
    let s = (64.0 / w as f64).min(48.0 / h as f64).min(1.0);
    (
        ((w as f64 * s).round() as u32).max(1),
        ((h as f64 * s).round() as u32).max(1),
    )
}

/// The config's budgets per mode (spp ladder first, then seconds).
fn mode_budgets(cfg: &Config) -> Vec<ModeBudgets> {
    cfg.modes()
        .iter()
        .map(|&m| ModeBudgets {
            mode: m,
            budgets: match m {
                BudgetMode::Spp => cfg
                    .budget
                    .spp
                    .as_ref()
                    .unwrap()
                    .iter()
                    .map(|&s| s as f64)
                    .collect(),
                BudgetMode::Time => cfg.budget.seconds.clone().unwrap(),
            },
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_size_keeps_aspect() {
        assert_eq!(quick_size(256, 256), (48, 48));
        assert_eq!(quick_size(640, 480), (64, 48));
        assert_eq!(quick_size(32, 16), (32, 16));
    }
}
