//! Command lines of merge, experiment, job, figures, report, gmm, diff, png and inspect parsed.

use super::{parse, refused};
use crate::cli::{Command, GmmCommand};
use crate::material::mixture::{FitMethod, FitOptions};
use clap::error::ErrorKind as ClapKind;
use std::path::{Path, PathBuf};

#[test]
fn merge_parses_shards_and_outputs() {
    let Command::Merge(a) =
        parse(&["merge", "a.exr", "b.exr", "-o", "m.exr", "--png", "m.png"]).unwrap()
    else {
        panic!("not merge");
    };
    assert_eq!(a.shards, [PathBuf::from("a.exr"), PathBuf::from("b.exr")]);
    assert_eq!(a.output, Path::new("m.exr"));
    assert_eq!(a.png, Some(PathBuf::from("m.png")));
    let e = refused(&["merge", "-o", "m.exr"]);
    assert_eq!(e.kind(), ClapKind::MissingRequiredArgument);
}

#[test]
fn experiment_parses_runs_plans_and_collects() {
    let Command::Experiment(a) =
        parse(&["experiment", "cfg.json", "--quick", "--out", "r"]).unwrap()
    else {
        panic!("not experiment");
    };
    assert_eq!(a.config, Some(PathBuf::from("cfg.json")));
    assert_eq!(a.out, Some(PathBuf::from("r")));
    assert!(a.quick && !a.plan && !a.slurm && a.collect.is_none());
    let Command::Experiment(a) = parse(&[
        "experiment",
        "cfg.json",
        "--slurm",
        "--partition",
        "gpu",
        "--time",
        "1:00:00",
        "--cpus-per-task",
        "4",
        "--reference-shards",
        "3",
        "--dry-run",
    ])
    .unwrap() else {
        panic!("not experiment");
    };
    assert!(a.slurm && a.dry_run);
    assert_eq!(a.partition.as_deref(), Some("gpu"));
    assert_eq!(a.time.as_deref(), Some("1:00:00"));
    assert_eq!((a.cpus_per_task, a.reference_shards), (Some(4), Some(3)));
    let Command::Experiment(a) = parse(&["experiment", "--collect", "run"]).unwrap() else {
        panic!("not experiment");
    };
    assert_eq!((a.config, a.collect), (None, Some(PathBuf::from("run"))));
    let conflict = refused(&["experiment", "cfg.json", "--plan", "--slurm"]);
    assert_eq!(conflict.kind(), ClapKind::ArgumentConflict);
    let conflict = refused(&["experiment", "cfg.json", "--collect", "run"]);
    assert_eq!(conflict.kind(), ClapKind::ArgumentConflict);
    let missing = refused(&["experiment"]);
    assert_eq!(missing.kind(), ClapKind::MissingRequiredArgument);
}

#[test]
fn job_figures_and_report_parse() {
    let Command::Job(a) = parse(&["job", "run", "3"]).unwrap() else {
        panic!("not job");
    };
    assert_eq!(
        (a.run_dir, a.index, a.all),
        (PathBuf::from("run"), Some(3), false)
    );
    let Command::Job(a) = parse(&["job", "run", "--all"]).unwrap() else {
        panic!("not job");
    };
    assert_eq!((a.index, a.all), (None, true));
    let e = refused(&["job", "run", "3", "--all"]);
    assert_eq!(e.kind(), ClapKind::ArgumentConflict);
    let Command::Figures {
        results_dir,
        plots_only,
    } = parse(&["figures", "results/x", "--plots-only"]).unwrap()
    else {
        panic!("not figures");
    };
    assert_eq!(
        (results_dir, plots_only),
        (PathBuf::from("results/x"), true)
    );
    let Command::Report { run_dir } = parse(&["report", "results/x/runs/1"]).unwrap() else {
        panic!("not report");
    };
    assert_eq!(run_dir, Path::new("results/x/runs/1"));
}

#[test]
fn gmm_fit_parses_and_defaults_to_the_core_fit_settings() {
    let gmm = |args: &[&str]| match parse(args) {
        Ok(Command::Gmm { command }) => command,
        _ => panic!("`{}` is not a gmm command", args.join(" ")),
    };
    let GmmCommand::Fit(a) = gmm(&["gmm", "fit", "x.bfc", "-o", "m.json"]) else {
        panic!("not fit");
    };
    let core = FitOptions::new(8, FitMethod::default(), 0);
    assert_eq!((a.input, a.output), ("x.bfc".into(), "m.json".into()));
    let fixed = |count| crate::cli::gmm::Components { count, auto: false };
    assert_eq!(
        (a.components, a.method, a.seed),
        (fixed(8), FitMethod::Em, 0)
    );
    assert_eq!(
        (a.max_iterations, a.tolerance),
        (core.max_iterations, core.tolerance)
    );
    assert_eq!((a.restarts, a.scale), (core.restarts, core.scale_method));
    let GmmCommand::Fit(a) = gmm(&[
        "gmm",
        "fit",
        "dir",
        "-o",
        "out",
        "--components",
        "4",
        "--method",
        "bayes",
        "--seed",
        "2",
        "--max-iterations",
        "50",
        "--tolerance",
        "1e-3",
    ]) else {
        panic!("not fit");
    };
    assert_eq!(
        (a.components, a.method, a.seed),
        (fixed(4), FitMethod::Bayes, 2)
    );
    assert_eq!((a.max_iterations, a.tolerance), (50, 1e-3));
    for (arg, count, auto) in [("auto", 8, true), ("auto:12", 12, true), ("32", 32, false)] {
        let GmmCommand::Fit(a) = gmm(&[
            "gmm",
            "fit",
            "x.bfc",
            "-o",
            "m.json",
            "--components",
            arg,
            "--restarts",
            "3",
            "--scale",
            "error",
        ]) else {
            panic!("not fit");
        };
        assert_eq!(a.components, crate::cli::gmm::Components { count, auto });
        assert_eq!(a.restarts, 3);
        assert_eq!(a.scale, crate::material::mixture::ScaleMethod::Error);
    }
    let GmmCommand::Dense(a) = gmm(&["gmm", "dense", "m.json", "--step", "5", "-o", "d.bfc"])
    else {
        panic!("not dense");
    };
    assert_eq!(
        (a.model, a.step, a.output),
        ("m.json".into(), 5.0, "d.bfc".into())
    );
    let GmmCommand::Dense(a) = gmm(&["gmm", "dense", "m.json", "-o", "d.bfc"]) else {
        panic!("not dense");
    };
    assert_eq!(a.step, 1.0);
}

#[test]
fn gmm_eval_parses_component_lists() {
    let Ok(Command::Gmm {
        command: GmmCommand::Eval(a),
    }) = parse(&["gmm", "eval", "rit"])
    else {
        panic!("not gmm eval");
    };
    assert_eq!(a.dir, Path::new("rit"));
    assert_eq!(a.components, [2, 4, 8]);
    assert_eq!((a.method, a.seed), (FitMethod::Em, 0));
    assert_eq!(a.output, Path::new(crate::gmm::evaluate::DEFAULT_OUT));
    let Ok(Command::Gmm {
        command: GmmCommand::Eval(a),
    }) = parse(&[
        "gmm",
        "eval",
        "rit",
        "--components",
        "1,3",
        "--method",
        "bayes",
        "--illuminants",
        "ill",
        "-o",
        "out",
    ])
    else {
        panic!("not gmm eval");
    };
    assert_eq!((a.components, a.method), (vec![1, 3], FitMethod::Bayes));
    assert_eq!(a.illuminants, Some(PathBuf::from("ill")));
    assert_eq!(a.output, Path::new("out"));
}

#[test]
fn diff_png_and_inspect_parse() {
    let Command::Diff(a) =
        parse(&["diff", "a.exr", "b.exr", "-o", "d.png", "--title", "T"]).unwrap()
    else {
        panic!("not diff");
    };
    assert_eq!((a.a, a.b), ("a.exr".into(), "b.exr".into()));
    assert_eq!((a.output, a.title), ("d.png".into(), Some("T".to_string())));
    let Command::Png(a) = parse(&["png", "in.exr", "-o", "out.png", "--exposure=-2"]).unwrap()
    else {
        panic!("not png");
    };
    assert_eq!((a.input, a.output), ("in.exr".into(), "out.png".into()));
    assert_eq!(a.exposure, Some(-2.0));
    let Command::Png(a) = parse(&["png", "in.exr", "-o", "out.png"]).unwrap() else {
        panic!("not png");
    };
    assert_eq!(a.exposure, None);
    let Command::Inspect { scene } = parse(&["inspect", "scene.json"]).unwrap() else {
        panic!("not inspect");
    };
    assert_eq!(scene, Path::new("scene.json"));
    let e = refused(&["inspect"]);
    assert_eq!(e.kind(), ClapKind::MissingRequiredArgument);
}

#[test]
fn gmm_figures_parses_fig4_options_and_defaults() {
    let Ok(Command::Gmm {
        command: GmmCommand::Figures(a),
    }) = parse(&["gmm", "figures", "rit"])
    else {
        panic!("not gmm figures");
    };
    assert_eq!(a.components, [2, 4, 8]);
    assert_eq!((a.material.as_str(), a.excitation), ("HERPICH", 440.0));
    assert_eq!((a.worst, a.output.is_none()), (5, true));
    let Ok(Command::Gmm {
        command: GmmCommand::Figures(a),
    }) = parse(&[
        "gmm",
        "figures",
        "rit",
        "--material",
        "golfye",
        "--excitation",
        "360",
        "-o",
        "figs",
    ])
    else {
        panic!("not gmm figures");
    };
    assert_eq!((a.material.as_str(), a.excitation), ("golfye", 360.0));
    assert_eq!(a.output.as_deref(), Some(Path::new("figs")));
}
