//! The parameter grid (Jung Fig. 7.13): the first variant rendered once per cell at the final
//! budget of the first mode, with two parameters of one material set to the cell's values.

use super::config::{BudgetMode, Grid};
use super::overrides::{self, Missing};
use super::progress::per_job;
use super::record::{GridCell, mkdir};
use super::setup::Setup;
use crate::error::Error;
use crate::film::output::write_exr;
use crate::integrator::{RenderSettings, render, with_threads};
use crate::scene::Scene;
use indicatif::ProgressBar;
use std::path::Path;

/// Render every cell of the config's grid (none without `grid`) into `<run_dir>/grid/`.
pub fn render_cells(s: &Setup, run_dir: &Path, bar: &ProgressBar) -> Result<Vec<GridCell>, Error> {
    let Some(g) = &s.cfg.grid else {
        return Ok(Vec::new());
    };
    mkdir(&run_dir.join("grid"))?;
    let mut cells = Vec::new();
    for (i, rv) in g.rows.values.iter().enumerate() {
        for (j, cv) in g.columns.values.iter().enumerate() {
            bar.set_message(format!(
                "grid {}={rv} {}={cv}",
                g.rows.field, g.columns.field
            ));
            cells.push(render_cell(s, g, (i, *rv), (j, *cv), run_dir)?);
            bar.inc(per_job(&s.modes[0]));
        }
    }
    super::record::write_text(&run_dir.join("grid.csv"), &cells_csv(g, &cells))?;
    Ok(cells)
}

/// Check every cell of the config's grid before anything renders: the scene with the cell's
/// values must load, and the first variant's integrator must accept it. Errors name the config
/// file, the cell and its values.
pub fn check_cells(s: &Setup) -> Result<(), Error> {
    let Some(g) = &s.cfg.grid else {
        return Ok(());
    };
    let v = &s.cfg.variants[0];
    for (i, rv) in g.rows.values.iter().enumerate() {
        for (j, cv) in g.columns.values.iter().enumerate() {
            let cell = |m: &str| {
                Error::input(format!(
                    "{}: field `grid`: cell ({i}, {j}) with {} = {rv}, {} = {cv}: {m}",
                    s.config_path.display(),
                    g.rows.field,
                    g.columns.field
                ))
            };
            let mut scene = scene_with_override(
                s,
                &g.material,
                &[(&g.rows.field, *rv), (&g.columns.field, *cv)],
            )
            .map_err(|e| cell(&e.message))?;
            s.resize(&mut scene);
            crate::integrator::render::check(&scene, v.integrator, &v.options)
                .map_err(|e| cell(&format!("integrator `{}`: {e}", v.integrator.name())))?;
        }
    }
    Ok(())
}

/// Cell (`i`, `j`) with the row parameter at `rv` and the column parameter at `cv`.
pub(super) fn render_cell(
    s: &Setup,
    g: &Grid,
    (i, rv): (usize, f64),
    (j, cv): (usize, f64),
    run_dir: &Path,
) -> Result<GridCell, Error> {
    let v = &s.cfg.variants[0];
    let mb = &s.modes[0];
    let last = *mb.budgets.last().unwrap();
    let mut scene = scene_with_override(
        s,
        &g.material,
        &[(&g.rows.field, rv), (&g.columns.field, cv)],
    )
    .map_err(|e| Error::input(format!("grid cell ({i}, {j}): {}", e.message)))?;
    s.resize(&mut scene);
    let settings = RenderSettings {
        first_sample: 0,
        spp: match mb.mode {
            BudgetMode::Spp => last as u32,
            BudgetMode::Time => u32::MAX,
        },
        seed: s.cfg.seed,
        threads: s.cfg.threads,
        time_limit: match mb.mode {
            BudgetMode::Spp => None,
            BudgetMode::Time => Some(last),
        },
        progress: false,
        spectral: None,
        cancel: s.cancel.clone(),
    };
    let out = render(&scene, v.integrator, &v.options, &settings, None)
        .map_err(|e| Error::runtime(format!("grid: {e}")))?;
    let file = format!("grid/r{i}_c{j}.exr");
    write_exr(&run_dir.join(&file), s.width, s.height, &out.film.rgb()).map_err(Error::runtime)?;
    Ok(GridCell {
        row: i,
        column: j,
        file,
        material_mean_y: material_mean_y(&scene, &g.material, &out.film.rgb()),
    })
}

/// Mean luminance Y of the pixels of the linear-sRGB image `rgb` whose first visible surface
/// has the material `name` (the quantity Jung Fig. 7.13's comparisons of cells need); `None`
/// when no pixel sees it. A cell's values change only spectra, so the base scene's pixels do.
pub fn material_mean_y(scene: &Scene, name: &str, rgb: &[glam::Vec3]) -> Option<f64> {
    let id = scene.material_names.iter().position(|n| n == name)? as u32;
    let (_, ids) = super::regions::region_ids(scene, super::config::RegionBy::Material);
    let (sum, n) = ids
        .iter()
        .zip(rgb)
        .filter(|(m, _)| **m == Some(id))
        .fold((0.0f64, 0usize), |(s, n), (_, c)| {
            (s + super::figures::luminance(*c), n + 1)
        });
    (n > 0).then(|| sum / n as f64)
}

/// The cells' material means as CSV: row, column, the two parameters' values, mean Y.
pub fn cells_csv(g: &Grid, cells: &[GridCell]) -> String {
    let mut out = format!(
        "row,column,{},{},material_mean_y\n",
        g.rows.field, g.columns.field
    );
    for c in cells {
        let y = c
            .material_mean_y
            .map_or(String::new(), |y| format!("{y:.6}"));
        out.push_str(&format!(
            "{},{},{},{},{y}\n",
            c.row, c.column, g.rows.values[c.row], g.columns.values[c.column]
        ));
    }
    out
}

/// Load the scene with the fields `overrides` of the grid's material set (inserted when the
/// material leaves them to their defaults).
fn scene_with_override(
    s: &Setup,
    material: &str,
    overrides: &[(&str, f64)],
) -> Result<Scene, Error> {
    let paths: Vec<(String, serde_json::Value)> = overrides
        .iter()
        .map(|(k, x)| (format!("materials.{material}.{k}"), serde_json::json!(x)))
        .collect();
    let text =
        overrides::apply(&s.scene_text, &s.scene_path, &paths, Missing::Insert).map_err(|e| {
            Error::input(format!(
                "grid.material: {e} in '{}'",
                s.scene_path.display()
            ))
        })?;
    let scene = with_threads(s.cfg.threads, || Scene::from_str(&s.scene_path, &text));
    Ok(scene.map_err(Error::runtime)??)
}
