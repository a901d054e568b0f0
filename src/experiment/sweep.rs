//! The sweep (Mojzík Figs. 18, 19): one scene parameter, named by a dot path into the scene
//! JSON, set to each value in turn. The runner runs the whole experiment (reference, regions,
//! variants, figures) once per value into `sweep/<index>/`, a run folder of its own; this module
//! makes the per-value setups and the `sweep.json` record, and picks the final-budget rows the
//! summary figure plots.

use super::config::Sweep;
use super::overrides::{self, Missing};
use super::record::{Row, SummaryEntry, summarize};
use super::setup::Setup;
use crate::error::Error;
use crate::integrator::with_threads;
use crate::io::InputError;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::Path;

/// One value of the sweep, ready to run.
pub struct Point {
    pub index: usize,
    pub value: Value,
    /// Its run folder, relative to the sweep's: `sweep/<index>`.
    pub dir: String,
    pub setup: Setup,
}

/// The setups of every value of the config's sweep (none without `sweep`), each scene loaded and
/// each integrator checked before anything renders. A path the scene lacks is an input error
/// naming `sweep.path`, the config file and the scene file.
pub fn points(s: &Setup) -> Result<Vec<Point>, Error> {
    let Some(sw) = &s.cfg.sweep else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for (index, value) in sw.values.iter().enumerate() {
        let text = overrides::apply(
            &s.scene_text,
            &s.scene_path,
            &[(sw.path.clone(), value.clone())],
            Missing::Fail,
        )
        .map_err(|e| {
            InputError::new(
                &s.config_path,
                "sweep.path",
                format!("{e} in the scene '{}'", s.scene_path.display()),
            )
        })?;
        let scene = with_threads(s.cfg.threads, || Scene::from_str(&s.scene_path, &text))
            .map_err(Error::runtime)?
            .map_err(|e| {
                Error::input(format!(
                    "{}: field `sweep.values[{index}]`: the scene with {} = {} is not valid: {e}",
                    s.config_path.display(),
                    sw.path,
                    compact(value)
                ))
            })?;
        let mut cfg = s.cfg.clone();
        cfg.sweep = None;
        // Only a title from here on (figures); the folder is `sweep/<index>`.
        cfg.name = format!("{} [{} = {}]", s.cfg.name, sw.label(), compact(value));
        let setup = s.with_scene(cfg, text, scene);
        setup.check_integrators()?;
        out.push(Point {
            index,
            value: value.clone(),
            dir: format!("sweep/{index}"),
            setup,
        });
    }
    Ok(out)
}

/// A value as short text: numbers and strings as they are, other JSON compacted.
pub fn compact(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        _ => v.to_string(),
    }
}

/// `sweep.json`: the swept path and, per value, its folder and final-budget SNR.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepRecord {
    pub path: String,
    pub label: String,
    pub points: Vec<PointRecord>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PointRecord {
    pub index: usize,
    pub value: Value,
    /// Run folder of this value, relative to the sweep's run folder.
    pub dir: String,
    /// Mean and spread over repeats at the final budget of each variant, mode and region.
    #[serde(rename = "final")]
    pub final_budget: Vec<SummaryEntry>,
}

impl SweepRecord {
    /// The record of `sw` from each point's metrics rows.
    pub fn new(sw: &Sweep, results: &[(&Point, Vec<Row>)]) -> SweepRecord {
        SweepRecord {
            path: sw.path.clone(),
            label: sw.label().to_string(),
            points: results
                .iter()
                .map(|(p, rows)| PointRecord {
                    index: p.index,
                    value: p.value.clone(),
                    dir: p.dir.clone(),
                    final_budget: final_entries(rows),
                })
                .collect(),
        }
    }

    /// Read `sweep.json` of the run folder `dir`; each value's folder must be a relative path
    /// inside the run folder.
    pub fn read(dir: &Path) -> Result<SweepRecord, Error> {
        let p = dir.join("sweep.json");
        let text =
            crate::io::input::read_text(&p, crate::io::input::RUN_RECORD).map_err(Error::input)?;
        let rec: SweepRecord = crate::io::json::from_json_str(&p, &text)?;
        for (i, pt) in rec.points.iter().enumerate() {
            if !super::record::safe_relative(&pt.dir) {
                return Err(Error::input(format!(
                    "{}: field `points[{i}].dir`: {:?} is not a folder inside the run folder",
                    p.display(),
                    pt.dir
                )));
            }
        }
        Ok(rec)
    }
}

/// The summary entries (mean over repeats) at the largest budget of each variant, mode and
/// region, in the order the rows first name them.
pub fn final_entries(rows: &[Row]) -> Vec<SummaryEntry> {
    let mut last: Vec<SummaryEntry> = Vec::new();
    for e in summarize(rows) {
        match last
            .iter_mut()
            .find(|p| p.variant == e.variant && p.mode == e.mode && p.region == e.region)
        {
            Some(p) if e.budget > p.budget => *p = e,
            Some(_) => {}
            None => last.push(e),
        }
    }
    last
}
