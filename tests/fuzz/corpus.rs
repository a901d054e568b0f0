//! The seed corpus and the cases built from it.
//!
//! Setup turns the shipped inputs into small, fast versions (the base): every scene with its
//! camera cut to at most 16 pixels a side and its data paths made absolute; every experiment
//! config pointing at those scenes, with two variants, one repeat, one thread and the smallest
//! budgets; run records made by running some of those configs (with their EXRs), plus the
//! committed ones under `results/` (text only); a fitted Gaussian-mixture model. A case copies
//! one input, mutates it, and names the `stokes` command that must cope with it.

use super::json::Json;
use super::mutate;
use rand::Rng;
use rand::seq::IndexedRandom;
use rand_pcg::Pcg64;
use std::path::{Path, PathBuf};

/// The largest camera side of a rendered mutant, in pixels.
pub const TINY: u32 = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    Scene,
    Config,
    Csv,
    Bfc,
    Vol,
    RunRecord,
    Exr,
    GmmModel,
    Obj,
    /// An input that is a FIFO, a device or a folder (tests/fuzz/special.rs).
    Special,
    /// Outputs onto devices, FIFOs, folders, links, long and non-ASCII names.
    Output,
    /// A finished planned run with its links or files edited by hand.
    RunFolder,
}

impl Kind {
    pub const ALL: [Kind; 12] = [
        Kind::Scene,
        Kind::Config,
        Kind::Csv,
        Kind::Bfc,
        Kind::Vol,
        Kind::RunRecord,
        Kind::Exr,
        Kind::GmmModel,
        Kind::Obj,
        Kind::Special,
        Kind::Output,
        Kind::RunFolder,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Scene => "scene",
            Kind::Config => "config",
            Kind::Csv => "csv",
            Kind::Bfc => "bfc",
            Kind::Vol => "vol",
            Kind::RunRecord => "run-record",
            Kind::Exr => "exr",
            Kind::GmmModel => "gmm-model",
            Kind::Obj => "obj",
            Kind::Special => "special-file",
            Kind::Output => "output",
            Kind::RunFolder => "run-folder",
        }
    }

    /// Share of the cases (out of 100). Configs cost the most per case.
    fn weight(self) -> u32 {
        match self {
            Kind::Scene => 23,
            Kind::Config => 10,
            Kind::Csv => 7,
            Kind::Bfc => 10,
            Kind::Vol => 7,
            Kind::RunRecord => 11,
            Kind::Exr => 7,
            Kind::GmmModel => 6,
            Kind::Obj => 4,
            Kind::Special => 5,
            Kind::Output => 4,
            Kind::RunFolder => 6,
        }
    }
}

/// What a successful (exit 0) run must also show.
#[derive(Clone, Debug)]
pub enum Check {
    /// `stokes render`: the stats JSON and the EXR.
    Render {
        stats: PathBuf,
        exr: PathBuf,
    },
    /// `stokes experiment`: every `metrics.csv` under this folder has finite errors.
    Experiment {
        out: PathBuf,
    },
    /// The command wrote this file.
    Output(PathBuf),
    Nothing,
}

pub struct Case {
    pub index: u64,
    pub kind: Kind,
    /// The shipped file the mutant came from (relative to the repository where it can be).
    pub input: String,
    pub mutation: String,
    pub dir: PathBuf,
    pub args: Vec<String>,
    pub check: Check,
    /// Paths that the run must leave as they were, whatever its exit code, with their
    /// fingerprints before it (tests/fuzz/special.rs).
    pub guards: Vec<(PathBuf, String)>,
}

pub struct Base {
    pub repo: PathBuf,
    pub dir: PathBuf,
    /// (repository-relative name, tiny scene) for every shipped scene.
    pub scenes: Vec<(String, Json)>,
    /// (repository-relative name, small config) for every shipped config.
    pub configs: Vec<(String, Json)>,
    pub csvs: Vec<PathBuf>,
    pub bfcs: Vec<PathBuf>,
    pub vols: Vec<PathBuf>,
    /// (label, folder): run records made at setup (with EXRs) and committed ones (without).
    pub runs: Vec<(String, PathBuf)>,
    pub gmm_models: Vec<PathBuf>,
    /// Strings worth trying wherever a string is: other data files, odd paths.
    pub strings: Vec<String>,
    /// A finished planned run (every job done, not collected): the folder holding its results
    /// root `results/`, and the run folder relative to that folder.
    pub planned: Option<(PathBuf, PathBuf)>,
}

impl Base {
    /// Scenes, configs and data files (no subprocess yet: the run records and the models are
    /// made by `setup_outputs` in tests/fuzz.rs).
    pub fn new(repo: &Path, dir: &Path) -> Base {
        std::fs::create_dir_all(dir.join("scenes")).unwrap();
        let mut scenes = Vec::new();
        let mut scale = std::collections::HashMap::new();
        for p in sorted_files(&repo.join("scenes"), "json") {
            let rel = rel(repo, &p);
            let mut doc = Json::parse(&std::fs::read_to_string(&p).unwrap())
                .unwrap_or_else(|e| panic!("{rel}: {e}"));
            absolute_paths(&mut doc, p.parent().unwrap());
            scale.insert(
                p.file_name().unwrap().to_owned(),
                tiny_camera(&mut doc, TINY),
            );
            fewer_fits(&mut doc);
            std::fs::write(
                dir.join("scenes").join(p.file_name().unwrap()),
                doc.to_text(),
            )
            .unwrap();
            scenes.push((rel, doc));
        }
        let mut configs = Vec::new();
        for p in sorted_files(&repo.join("experiments"), "json") {
            let rel = rel(repo, &p);
            let mut doc = Json::parse(&std::fs::read_to_string(&p).unwrap())
                .unwrap_or_else(|e| panic!("{rel}: {e}"));
            small_config(&mut doc, p.parent().unwrap(), &dir.join("scenes"), &scale);
            configs.push((rel, doc));
        }
        let csvs = sorted_files(&repo.join("data/spectra/illuminants"), "csv");
        let mut bfcs = sorted_files(&repo.join("data/bispectral"), "BFC");
        bfcs.extend(sorted_files(&repo.join("data/bispectral/rit"), "BFC"));
        let vols = sorted_files(&repo.join("scenes/media"), "vol");
        let strings = vec![
            csvs[0].display().to_string(),
            bfcs[0].display().to_string(),
            vols[0].display().to_string(),
            repo.join("scenes/cornell-box.json").display().to_string(),
            repo.join("data/spectra/cie1931_2deg_xyz_1nm.csv")
                .display()
                .to_string(),
            repo.join("data/spectra/macbeth_patches.csv")
                .display()
                .to_string(),
            repo.join("data").display().to_string(),
            "/dev/null".into(),
        ];
        Base {
            repo: repo.to_path_buf(),
            dir: dir.to_path_buf(),
            scenes,
            configs,
            csvs,
            bfcs,
            vols,
            runs: Vec::new(),
            gmm_models: Vec::new(),
            strings,
            planned: None,
        }
    }

    /// Base scenes whose JSON mentions a file with this extension (absolute paths by now).
    fn scenes_with(&self, ext: &str) -> Vec<&(String, Json)> {
        self.scenes
            .iter()
            .filter(|(_, d)| !file_strings(d, ext).is_empty())
            .collect()
    }

    pub fn config(&self, name: &str) -> &Json {
        &self
            .configs
            .iter()
            .find(|(n, _)| n.ends_with(name))
            .unwrap()
            .1
    }

    /// Build case `index`.
    pub fn case(&self, rng: &mut Pcg64, index: u64, kinds: &[Kind], dir: &Path) -> Case {
        std::fs::create_dir_all(dir).unwrap();
        let total: u32 = kinds.iter().map(|k| k.weight()).sum();
        let mut r = rng.random_range(0..total);
        let mut kind = kinds[0];
        for &k in kinds {
            if r < k.weight() {
                kind = k;
                break;
            }
            r -= k.weight();
        }
        let n = match rng.random_range(0..100) {
            0..70 => 1,
            70..90 => 2,
            _ => 3,
        };
        let mut c = match kind {
            Kind::Scene => self.scene_case(rng, n, dir),
            Kind::Config => self.config_case(rng, n, dir),
            Kind::Csv => self.csv_case(rng, n, dir),
            Kind::Bfc => self.bfc_case(rng, n, dir),
            Kind::Vol => self.vol_case(rng, n, dir),
            Kind::RunRecord => self.run_case(rng, n, dir),
            Kind::Exr => self.exr_case(rng, n, dir),
            Kind::GmmModel => self.gmm_case(rng, n, dir),
            Kind::Obj => self.obj_case(rng, n, dir),
            Kind::Special => self.special_case(rng, dir),
            Kind::Output => self.output_case(rng, dir),
            Kind::RunFolder => self.run_folder_case(rng, n, dir),
        };
        c.index = index;
        c
    }

    fn scene_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let (name, doc) = self.scenes.choose(rng).unwrap();
        let path = dir.join("scene.json");
        let desc = self.mutate_json_file(rng, doc, n, &path, |d| {
            tiny_camera_clamp(d);
        });
        let mut c = render_case(rng, dir, &path);
        c.kind = Kind::Scene;
        c.input = name.clone();
        c.mutation = desc;
        c
    }

    fn config_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let (name, doc) = self.configs.choose(rng).unwrap();
        let path = dir.join("config.json");
        let desc = self.mutate_json_file(rng, doc, n, &path, clamp_config);
        let mut c = experiment_case(dir, &path);
        c.input = name.clone();
        c.mutation = desc;
        c
    }

    /// Mutate `doc` (as JSON, or as text one time in six), apply `fix` (the tiny-render limits)
    /// when the result still parses, and write it to `path`.
    pub fn mutate_json_file(
        &self,
        rng: &mut Pcg64,
        doc: &Json,
        n: usize,
        path: &Path,
        fix: impl Fn(&mut Json),
    ) -> String {
        let mut doc = doc.clone();
        if rng.random_bool(1.0 / 16.0) {
            // Data after the document: stokes must not stop reading at its end.
            let tail = *[
                "\0",
                "\0\0\0\0",
                "x",
                "\n{}",
                "]}",
                "\n# comment",
                "\u{feff}",
                "\n\n1",
            ]
            .choose(rng)
            .unwrap();
            std::fs::write(path, format!("{}{tail}", doc.to_text())).unwrap();
            return format!("text: trailing {tail:?}");
        }
        if rng.random_bool(1.0 / 6.0) {
            let mut bytes = doc.to_text().into_bytes();
            let d = mutate::text(rng, &mut bytes, n, 0);
            if let Ok(mut j) = Json::parse(&String::from_utf8_lossy(&bytes))
                && std::str::from_utf8(&bytes).is_ok()
            {
                fix(&mut j);
                bytes = j.to_text().into_bytes();
            }
            std::fs::write(path, bytes).unwrap();
            format!("text: {}", d.join("; "))
        } else {
            let d = mutate::json(rng, &mut doc, n, &self.strings);
            fix(&mut doc);
            std::fs::write(path, doc.to_text()).unwrap();
            d.join("; ")
        }
    }

    fn csv_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let src = self.csvs.choose(rng).unwrap();
        let mutant = dir.join(src.file_name().unwrap());
        let mut bytes = std::fs::read(src).unwrap();
        let d = mutate::text(rng, &mut bytes, n, 1);
        std::fs::write(&mutant, bytes).unwrap();
        let (_, scene) = *self.scenes_with("csv").choose(rng).unwrap();
        let path = dir.join("scene.json");
        let note = replace_one_file(rng, scene, "csv", &mutant, &path);
        let mut c = render_case(rng, dir, &path);
        c.kind = Kind::Csv;
        c.input = rel(&self.repo, src);
        c.mutation = format!("{}; {note}", d.join("; "));
        c
    }

    fn bfc_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let src = self.bfcs.choose(rng).unwrap();
        let mutant = dir.join(src.file_name().unwrap());
        let mut bytes = std::fs::read(src).unwrap();
        let d = mutate::text(rng, &mut bytes, n, 12);
        std::fs::write(&mutant, bytes).unwrap();
        let input = rel(&self.repo, src);
        let how = rng.random_range(0..100);
        let mut c = if how < 15 {
            // Fit it directly.
            let out = dir.join("fit.json");
            let mut c = plain_case(
                dir,
                vec![
                    "gmm".into(),
                    "fit".into(),
                    s(&mutant),
                    "--components".into(),
                    "2".into(),
                    "-o".into(),
                    s(&out),
                ],
            );
            c.check = Check::Output(out);
            c.mutation = format!("{}; stokes gmm fit", d.join("; "));
            c
        } else {
            // Render it: as a measured matrix (`file`), or fitted at load (`bfc`).
            let ext_key = if how < 70 { "file" } else { "bfc" };
            let scenes: Vec<&(String, Json)> = self
                .scenes_with("BFC")
                .into_iter()
                .filter(|(_, d)| has_key_with_ext(d, ext_key, "BFC"))
                .collect();
            let (_, scene) = *scenes.choose(rng).unwrap();
            let path = dir.join("scene.json");
            let note = replace_one_file(rng, scene, "BFC", &mutant, &path);
            let mut c = render_case(rng, dir, &path);
            c.mutation = format!("{}; {note} ({ext_key})", d.join("; "));
            c
        };
        c.kind = Kind::Bfc;
        c.input = input;
        c
    }

    fn vol_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let src = self.vols.choose(rng).unwrap();
        let mutant = dir.join(src.file_name().unwrap());
        let mut bytes = std::fs::read(src).unwrap();
        let d = mutate::vol(rng, &mut bytes, n);
        std::fs::write(&mutant, bytes).unwrap();
        let (_, scene) = *self.scenes_with("vol").choose(rng).unwrap();
        let path = dir.join("scene.json");
        let note = replace_one_file(rng, scene, "vol", &mutant, &path);
        let mut c = render_case(rng, dir, &path);
        c.kind = Kind::Vol;
        c.input = rel(&self.repo, src);
        c.mutation = format!("{}; {note}", d.join("; "));
        c
    }

    fn run_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let (label, src) = self.runs.choose(rng).unwrap();
        let run = dir.join("run");
        copy_run(src, &run);
        let files: Vec<PathBuf> = walk(&run)
            .into_iter()
            .filter(|p| {
                let e = ext(p);
                e == "json" || e == "csv"
            })
            .collect();
        let f = files.choose(rng).unwrap();
        let mut bytes = std::fs::read(f).unwrap();
        let d = if ext(f) == "json" && rng.random_bool(0.8) {
            let mut doc = Json::parse(&String::from_utf8_lossy(&bytes)).unwrap();
            let d = mutate::json(rng, &mut doc, n, &self.strings);
            bytes = doc.to_text().into_bytes();
            d
        } else {
            mutate::text(rng, &mut bytes, n, 1)
        };
        std::fs::write(f, bytes).unwrap();
        let mut c = plain_case(dir, vec!["figures".into(), s(&run)]);
        c.kind = Kind::RunRecord;
        c.input = label.clone();
        c.mutation = format!("{}: {}", rel(&run, f), d.join("; "));
        c
    }

    fn exr_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let with_exrs: Vec<&(String, PathBuf)> = self
            .runs
            .iter()
            .filter(|(_, p)| walk(p).iter().any(|f| ext(f) == "exr"))
            .collect();
        let (label, src) = *with_exrs.choose(rng).unwrap();
        if rng.random_bool(0.6) {
            // An image of a run record, then `stokes figures`.
            let run = dir.join("run");
            copy_run(src, &run);
            let exrs: Vec<PathBuf> = walk(&run).into_iter().filter(|f| ext(f) == "exr").collect();
            let f = exrs.choose(rng).unwrap();
            let mut bytes = std::fs::read(f).unwrap();
            let d = mutate::exr(rng, &mut bytes, n);
            std::fs::write(f, bytes).unwrap();
            let mut c = plain_case(dir, vec!["figures".into(), s(&run)]);
            c.kind = Kind::Exr;
            c.input = format!("{label}/{}", rel(&run, f));
            c.mutation = d.join("; ");
            c
        } else {
            // The reference image of an experiment config (`reference: {"exr": ...}`).
            let f = walk(src)
                .into_iter()
                .find(|f| f.file_name().unwrap() == "reference.exr")
                .unwrap_or_else(|| walk(src).into_iter().find(|f| ext(f) == "exr").unwrap());
            let mutant = dir.join("reference.exr");
            let mut bytes = std::fs::read(&f).unwrap();
            let d = mutate::exr(rng, &mut bytes, n);
            std::fs::write(&mutant, bytes).unwrap();
            let mut cfg = self.config("smoke-pt-mono.json").clone();
            cfg.set(
                "reference",
                Json::Obj(vec![("exr".into(), Json::Str(s(&mutant)))]),
            );
            let path = dir.join("config.json");
            std::fs::write(&path, cfg.to_text()).unwrap();
            let mut c = experiment_case(dir, &path);
            c.kind = Kind::Exr;
            c.input = format!("{label}/{}", rel(src, &f));
            c.mutation = format!("{}; as reference.exr of a config", d.join("; "));
            c
        }
    }

    fn gmm_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let src = self.gmm_models.choose(rng).unwrap();
        let mutant = dir.join(src.file_name().unwrap());
        let text = std::fs::read_to_string(src).unwrap();
        let mut doc = Json::parse(&text).unwrap();
        let d = if rng.random_bool(0.85) {
            let d = mutate::json(rng, &mut doc, n, &self.strings);
            std::fs::write(&mutant, doc.to_text()).unwrap();
            d
        } else {
            let mut bytes = text.into_bytes();
            let d = mutate::text(rng, &mut bytes, n, 0);
            std::fs::write(&mutant, bytes).unwrap();
            d
        };
        let input = format!("gmm fit of {}", src.file_stem().unwrap().to_string_lossy());
        let mut c = if rng.random_bool(0.5) {
            let out = dir.join("dense.BFC");
            let step = *["1", "5", "10"].choose(rng).unwrap();
            let mut c = plain_case(
                dir,
                vec![
                    "gmm".into(),
                    "dense".into(),
                    s(&mutant),
                    "--step".into(),
                    step.into(),
                    "-o".into(),
                    s(&out),
                ],
            );
            c.check = Check::Output(out);
            c.mutation = format!("{}; stokes gmm dense --step {step}", d.join("; "));
            c
        } else {
            // A scene whose Gaussian-mixture material reads the model file.
            let (_, scene) = *self
                .scenes
                .iter()
                .filter(|(_, d)| has_key_with_ext(d, "bfc", "BFC"))
                .collect::<Vec<_>>()
                .choose(rng)
                .unwrap();
            let mut scene = scene.clone();
            let mats = scene.get_mut("materials").unwrap();
            if let Json::Obj(m) = mats {
                let gmm: Vec<usize> = (0..m.len())
                    .filter(|&i| m[i].1.get("bfc").is_some())
                    .collect();
                let i = *gmm.choose(rng).unwrap();
                m[i].1 = Json::Obj(vec![
                    ("type".into(), Json::Str("reradiation-gmm".into())),
                    ("file".into(), Json::Str(s(&mutant))),
                ]);
            }
            let path = dir.join("scene.json");
            std::fs::write(&path, scene.to_text()).unwrap();
            let mut c = render_case(rng, dir, &path);
            c.mutation = format!("{}; as a reradiation-gmm file", d.join("; "));
            c
        };
        c.kind = Kind::GmmModel;
        c.input = input;
        c
    }
}

impl Base {
    /// The unmutated OBJ case (for the check of the base corpus).
    pub fn obj_unmutated(&self, dir: &Path) -> Case {
        use rand::SeedableRng;
        std::fs::create_dir_all(dir).unwrap();
        self.obj_case(&mut Pcg64::seed_from_u64(0), 0, dir)
    }

    /// An OBJ mesh (no OBJ ships with stokes: a cube with texture coordinates, normals, a
    /// material library, quads and a triangle fan), mutated as text and rendered as an `obj`
    /// shape in the tiny Cornell box.
    fn obj_case(&self, rng: &mut Pcg64, n: usize, dir: &Path) -> Case {
        let mut bytes = CUBE_OBJ.as_bytes().to_vec();
        let d = mutate::text(rng, &mut bytes, n, 4);
        std::fs::write(dir.join("cube.obj"), bytes).unwrap();
        std::fs::write(dir.join("cube.mtl"), CUBE_MTL).unwrap();
        let mut scene = self
            .scenes
            .iter()
            .find(|(n, _)| n.ends_with("cornell-box.json"))
            .unwrap()
            .1
            .clone();
        if let Some(Json::Arr(shapes)) = scene.get_mut("shapes") {
            let material = shapes[0].get("material").unwrap().clone();
            shapes.push(Json::Obj(vec![
                ("type".into(), Json::Str("obj".into())),
                ("name".into(), Json::Str("mesh".into())),
                ("material".into(), material),
                ("file".into(), Json::Str(s(&dir.join("cube.obj")))),
                ("scale".into(), Json::num(0.25)),
                (
                    "translate".into(),
                    Json::Arr(vec![Json::num(0.0), Json::num(-0.5), Json::num(0.0)]),
                ),
            ]));
        }
        let path = dir.join("scene.json");
        std::fs::write(&path, scene.to_text()).unwrap();
        let mut c = render_case(rng, dir, &path);
        c.kind = Kind::Obj;
        c.input = "cube.obj (made by the harness)".into();
        c.mutation = d.join("; ");
        c
    }
}

const CUBE_OBJ: &str = "# a unit cube\nmtllib cube.mtl\no cube\ng faces\n\
v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n\
usemtl grey\ns off\n\
f 4/4/1 3/3/1 2/2/1 1/1/1\nf 5/1/2 6/2/2 7/3/2 8/4/2\nf 1/1/3 2/2/3 6/3/3 5/4/3\n\
f 8//4 7//4 3//4 4//4\nf 1 5 8 4\nf 2 3 7\nf 2 7 6\n";

const CUBE_MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\n";

pub fn plain_case(dir: &Path, args: Vec<String>) -> Case {
    Case {
        index: 0,
        kind: Kind::Scene,
        input: String::new(),
        mutation: String::new(),
        dir: dir.to_path_buf(),
        args,
        check: Check::Nothing,
        guards: Vec::new(),
    }
}

/// `stokes render` of a scene at 1–4 spp with one thread, a random integrator and random (valid)
/// integrator options.
pub fn render_case(rng: &mut Pcg64, dir: &Path, scene: &Path) -> Case {
    let integrator = *[
        "pt-mono",
        "pt-hero",
        "bdpt-forward",
        "bdpt-backward",
        "bdpt-allbins",
    ]
    .choose(rng)
    .unwrap();
    let stats = dir.join("stats.json");
    let exr = dir.join("out.exr");
    let mut args: Vec<String> = vec![
        "render".into(),
        s(scene),
        "--integrator".into(),
        integrator.into(),
        "--spp".into(),
        rng.random_range(1..=4u32).to_string(),
        "--seed".into(),
        rng.random_range(0..1000u32).to_string(),
        "--threads".into(),
        "1".into(),
        "--stats".into(),
        s(&stats),
        "-o".into(),
        s(&exr),
    ];
    // Half the renders use the defaults; the others change some options.
    if rng.random_bool(0.5) {
        let options: [(&str, &[&str]); 9] = [
            ("--max-depth", &["1", "2", "3", "16"]),
            ("--camera-wavelengths", &["uniform", "cmf"]),
            ("--wavelength-sampling", &["importance", "uniform"]),
            ("--lanes", &["1", "2", "8", "16"]),
            ("--light-wavelengths", &["emission", "uniform"]),
            ("--mis", &["balance", "power"]),
            ("--tracking", &["aware", "max", "exponential"]),
            ("--bin-width", &["1", "10", "20", "100"]),
            ("--rr-depth", &["1", "3"]),
        ];
        for (flag, values) in options {
            if rng.random_bool(0.3) {
                args.push(flag.into());
                args.push(values.choose(rng).unwrap().to_string());
            }
        }
    }
    let mut c = plain_case(dir, args);
    c.check = Check::Render { stats, exr };
    c
}

pub fn experiment_case(dir: &Path, config: &Path) -> Case {
    let out = dir.join("out");
    let mut c = plain_case(
        dir,
        vec![
            "experiment".into(),
            s(config),
            "--quick".into(),
            "--out".into(),
            s(&out),
        ],
    );
    c.kind = Kind::Config;
    c.check = Check::Experiment { out };
    c
}

pub fn s(p: &Path) -> String {
    p.display().to_string()
}

pub fn ext(p: &Path) -> String {
    p.extension()
        .map(|e| e.to_string_lossy().to_string())
        .unwrap_or_default()
}

pub fn rel(base: &Path, p: &Path) -> String {
    p.strip_prefix(base).unwrap_or(p).display().to_string()
}

fn sorted_files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

/// Every file below `dir`.
pub fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut entries: Vec<PathBuf> = rd.map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        // links are not followed (a case may link a run's folder elsewhere)
        if std::fs::symlink_metadata(&p).is_ok_and(|m| m.is_dir()) {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// Copy a folder and everything in it (links copied as links).
pub fn copy_tree(src: &Path, dst: &Path) {
    std::fs::create_dir_all(dst).unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let e = e.unwrap();
        let (p, t) = (e.path(), dst.join(e.file_name()));
        let ft = e.file_type().unwrap();
        if ft.is_dir() {
            copy_tree(&p, &t);
        } else if ft.is_symlink() {
            std::os::unix::fs::symlink(std::fs::read_link(&p).unwrap(), &t).unwrap();
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

/// Copy a run folder without its `figures/` (outputs, not inputs).
pub fn copy_run(src: &Path, dst: &Path) {
    std::fs::create_dir_all(dst).unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap();
        if p.is_dir() {
            if name != "figures" {
                copy_run(&p, &dst.join(name));
            }
        } else {
            std::fs::copy(&p, dst.join(name)).unwrap();
        }
    }
}

/// Make the relative file references of a scene or config absolute.
fn absolute_paths(doc: &mut Json, base: &Path) {
    match doc {
        Json::Obj(m) => {
            for (k, v) in m.iter_mut() {
                match v {
                    Json::Str(p) if matches!(k.as_str(), "file" | "bfc" | "scene" | "exr") => {
                        let q = base.join(&*p);
                        *p = s(&std::fs::canonicalize(&q).unwrap_or(q));
                    }
                    _ => absolute_paths(v, base),
                }
            }
        }
        Json::Arr(a) => a.iter_mut().for_each(|v| absolute_paths(v, base)),
        _ => {}
    }
}

/// Shrink the camera to at most `max` pixels a side, keeping the aspect ratio; returns the
/// factor (new / old).
fn tiny_camera(doc: &mut Json, max: u32) -> f64 {
    let cam = doc.get_mut("camera").unwrap();
    let w = cam.get("width").and_then(Json::as_f64).unwrap();
    let h = cam.get("height").and_then(Json::as_f64).unwrap();
    let k = (w.max(h) / max as f64).max(1.0);
    cam.set("width", Json::num((w / k).round().max(1.0)));
    cam.set("height", Json::num((h / k).round().max(1.0)));
    (w / k).round().max(1.0) / w
}

/// After a mutation: a camera side that is a plausible image size but larger than the tiny
/// render's is cut back, so a valid mutant never renders for long. Sizes past 65536 stay, since
/// stokes must refuse those itself.
fn tiny_camera_clamp(doc: &mut Json) {
    if let Some(cam) = doc.get_mut("camera") {
        for key in ["width", "height"] {
            if let Some(v) = cam.get(key).and_then(Json::as_f64)
                && v > TINY as f64
                && v <= 65536.0
                && v.fract() == 0.0
            {
                cam.set(key, Json::num(TINY as f64));
            }
        }
    }
}

/// After a mutation of a config: a valid but deep `max_depth` is cut back to 16, and a valid but
/// large `threads` (up to the 1024 stokes accepts: spawning them costs seconds) back to 2.
fn clamp_config(doc: &mut Json) {
    match doc {
        Json::Obj(m) => {
            for (k, v) in m.iter_mut() {
                let limit = match k.as_str() {
                    "max_depth" => Some((16.0, 1024.0)),
                    "threads" => Some((2.0, 1024.0)),
                    _ => None,
                };
                if let Some((to, max)) = limit
                    && let Some(d) = v.as_f64()
                    && d > to
                    && d <= max
                {
                    *v = Json::num(to);
                } else {
                    clamp_config(v);
                }
            }
        }
        Json::Arr(a) => a.iter_mut().for_each(clamp_config),
        _ => {}
    }
}

/// Scenes that fit Gaussian mixtures when they load keep three of those materials (and their
/// shapes), so that a mutated `components` of 32 still fits in well under a second.
fn fewer_fits(doc: &mut Json) {
    let Some(Json::Obj(mats)) = doc.get_mut("materials") else {
        return;
    };
    let fitted: Vec<String> = mats
        .iter()
        .filter(|(_, v)| v.get("bfc").is_some())
        .map(|(k, _)| k.clone())
        .collect();
    if fitted.len() <= 3 {
        return;
    }
    let drop: Vec<String> = fitted[3..].to_vec();
    mats.retain(|(k, _)| !drop.contains(k));
    if let Some(Json::Arr(shapes)) = doc.get_mut("shapes") {
        shapes.retain(|sh| match sh.get("material") {
            Some(Json::Str(m)) => !drop.contains(m),
            _ => true,
        });
    }
}

/// The small version of a config: its scenes are the tiny base scenes (crop and scanline scaled
/// to match), two variants, one repeat, one thread, the smallest budgets.
fn small_config(
    doc: &mut Json,
    cfg_dir: &Path,
    scene_dir: &Path,
    scale: &std::collections::HashMap<std::ffi::OsString, f64>,
) {
    let to_tiny = |v: &mut Json| -> f64 {
        if let Json::Str(p) = v {
            let name = Path::new(p.as_str()).file_name().unwrap().to_owned();
            let f = scale[&name];
            *p = s(&scene_dir.join(&name));
            f
        } else {
            1.0
        }
    };
    let f = to_tiny(doc.get_mut("scene").unwrap());
    let mut kept = Vec::new();
    if let Some(Json::Arr(vs)) = doc.get_mut("variants") {
        vs.truncate(2);
        for v in vs.iter_mut() {
            if let Some(sc) = v.get_mut("scene") {
                to_tiny(sc);
            }
            kept.extend(v.get("name").cloned());
        }
    }
    // The signed difference names variants: point it at the ones kept.
    if let Some(d) = doc.get_mut("difference") {
        for (k, name) in ["a", "b"].into_iter().zip(kept) {
            if d.get(k).is_some() {
                d.set(k, name);
            }
        }
    }
    absolute_paths(doc, cfg_dir);
    let scaled = |v: f64| Json::num((v * f).floor());
    if let Some(c) = doc.get_mut("crop") {
        for k in ["x", "y", "w", "h"] {
            if let Some(v) = c.get(k).and_then(Json::as_f64) {
                let n = (v * f).floor();
                c.set(
                    k,
                    Json::num(if k == "w" || k == "h" { n.max(1.0) } else { n }),
                );
            }
        }
    }
    if let Some(sl) = doc.get_mut("scanline") {
        for k in ["row", "column"] {
            if let Some(v) = sl.get(k).and_then(Json::as_f64) {
                sl.set(k, scaled(v));
            }
        }
    }
    if let Some(b) = doc.get_mut("budget") {
        if b.get("spp").is_some() {
            b.set("spp", Json::Arr(vec![Json::num(1.0), Json::num(2.0)]));
        }
        if b.get("seconds").is_some() {
            b.set("seconds", Json::Arr(vec![Json::num(1.0)]));
        }
    }
    if let Some(r) = doc.get_mut("reference")
        && r.get("spp").is_some()
    {
        r.set("spp", Json::num(16.0));
    }
    doc.set("repeats", Json::num(1.0));
    doc.set("threads", Json::num(1.0));
    if let Some(g) = doc.get_mut("grid") {
        for axis in ["rows", "columns"] {
            if let Some(Json::Arr(v)) = g.get_mut(axis).and_then(|a| a.get_mut("values")) {
                v.truncate(2);
            }
        }
    }
    if let Some(Json::Arr(v)) = doc.get_mut("sweep").and_then(|sw| sw.get_mut("values")) {
        v.truncate(2);
    }
}

/// The string values (file paths) of a document that end in `.ext`.
pub fn file_strings(doc: &Json, ext: &str) -> Vec<String> {
    let mut out = Vec::new();
    match doc {
        Json::Str(s) if s.ends_with(&format!(".{ext}")) => out.push(s.clone()),
        Json::Arr(a) => a.iter().for_each(|v| out.extend(file_strings(v, ext))),
        Json::Obj(m) => m.iter().for_each(|(_, v)| out.extend(file_strings(v, ext))),
        _ => {}
    }
    out
}

pub fn has_key_with_ext(doc: &Json, key: &str, ext: &str) -> bool {
    match doc {
        Json::Arr(a) => a.iter().any(|v| has_key_with_ext(v, key, ext)),
        Json::Obj(m) => m.iter().any(|(k, v)| {
            matches!(v, Json::Str(s) if k == key && s.ends_with(&format!(".{ext}")))
                || has_key_with_ext(v, key, ext)
        }),
        _ => false,
    }
}

/// Write `scene` to `out` with one of its `.ext` file references (chosen at random) pointing at
/// `mutant`.
pub fn replace_one_file(
    rng: &mut Pcg64,
    scene: &Json,
    ext: &str,
    mutant: &Path,
    out: &Path,
) -> String {
    let mut doc = scene.clone();
    let candidates: Vec<Vec<super::json::Step>> = doc
        .paths()
        .into_iter()
        .filter(|p| matches!(doc.at(p), Json::Str(s) if s.ends_with(&format!(".{ext}"))))
        .collect();
    let p = candidates.choose(rng).unwrap().clone();
    let name = doc.path_name(&p);
    *doc.at_mut(&p) = Json::Str(s(mutant));
    std::fs::write(out, doc.to_text()).unwrap();
    format!("used as {name}")
}
