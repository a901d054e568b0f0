//! Command lines parsed by the real top-level parser: the enum options, defaults, `--set`, render.

mod commands;

use super::{Choice, Cli, Command, RenderArgs, parse_sets};
use crate::ErrorKind;
use crate::integrator::{
    IntegratorKind, IntegratorOptions, LaneWeighting, LightWavelengths, MisHeuristic,
};
use crate::material::WavelengthSampling;
use crate::material::mixture::FitMethod;
use crate::medium::Tracking;
use crate::spectrum::cie::CameraWavelengths;
use clap::error::ErrorKind as ClapKind;
use clap::{CommandFactory, Parser};
use std::path::{Path, PathBuf};

/// The command of `stokes ARGS…`.
pub(super) fn parse(args: &[&str]) -> Result<Command, clap::Error> {
    Cli::try_parse_from(std::iter::once("stokes").chain(args.iter().copied())).map(|c| c.command)
}

/// The arguments of `stokes render scene.json -o out.exr EXTRA…`.
fn render(extra: &[&str]) -> RenderArgs {
    let mut args = vec!["render", "scene.json", "-o", "out.exr"];
    args.extend_from_slice(extra);
    match parse(&args) {
        Ok(Command::Render(a)) => *a,
        Ok(_) => panic!("`{}` parsed as another command", args.join(" ")),
        Err(e) => panic!("`{}` does not parse: {e}", args.join(" ")),
    }
}

/// The error of a command line that must not parse.
pub(super) fn refused(args: &[&str]) -> clap::Error {
    match parse(args) {
        Ok(_) => panic!("`{}` parsed", args.join(" ")),
        Err(e) => e,
    }
}

/// The argument `--long` of the subcommand at `path` (e.g. `["gmm", "fit"]`).
fn argument(path: &[&str], long: &str) -> clap::Arg {
    let mut cmd = Cli::command();
    for name in path {
        cmd = cmd
            .find_subcommand(name)
            .unwrap_or_else(|| panic!("no subcommand {name}"))
            .clone();
    }
    cmd.get_arguments()
        .find(|a| a.get_long() == Some(long))
        .unwrap_or_else(|| panic!("no --{long} in {}", path.join(" ")))
        .clone()
}

/// The default values `--long` shows in its help.
fn shown_defaults(path: &[&str], long: &str) -> Vec<String> {
    argument(path, long)
        .get_default_values()
        .iter()
        .map(|v| v.to_string_lossy().into_owned())
        .collect()
}

#[test]
fn the_parser_passes_clap_debug_asserts() {
    Cli::command().debug_assert();
}

#[test]
fn every_integrator_name_parses_for_render() {
    let mut names = Vec::new();
    for kind in IntegratorKind::ALL {
        assert_eq!(render(&["--integrator", kind.name()]).integrator, kind);
        names.push(kind.name());
    }
    assert_eq!(
        names,
        [
            "pt-mono",
            "pt-hero",
            "bdpt-forward",
            "bdpt-backward",
            "bdpt-combined",
            "bdpt-allbins"
        ]
    );
}

#[test]
fn parsed_render_defaults_are_the_core_defaults() {
    let a = render(&[]);
    assert_eq!(a.options(), IntegratorOptions::default());
    assert_eq!(a.integrator, IntegratorKind::PtMono);
    assert_eq!((a.spp, a.seed, a.exposure), (16, 0, 0.0));
    assert_eq!((a.samples, a.sample_range()), (None, (0, 16)));
    assert_eq!((a.threads, a.time_limit, a.rr_depth), (None, None, None));
    assert!(a.set.is_empty() && !a.quiet);
}

#[test]
fn render_help_shows_the_core_defaults() {
    let d = IntegratorOptions::default();
    let shown = |long| shown_defaults(&["render"], long);
    assert_eq!(shown("max-depth"), [d.max_depth.to_string()]);
    assert_eq!(shown("lanes"), [d.lanes.to_string()]);
    assert_eq!(shown("bin-width"), [d.bin_width.to_string()]);
    assert_eq!(shown("camera-wavelengths"), [d.camera_wavelengths.name()]);
    assert_eq!(shown("wavelength-sampling"), [d.wavelength_sampling.name()]);
    assert_eq!(shown("light-wavelengths"), [d.light_wavelengths.name()]);
    assert_eq!(shown("mis"), [d.mis.name()]);
    assert_eq!(shown("tracking"), [d.tracking.name()]);
    assert_eq!(shown("lane-weighting"), [d.lane_weighting.name()]);
    assert_eq!(shown("integrator"), ["pt-mono"]);
    assert!(shown("rr-depth").is_empty());
}

#[test]
fn every_enum_option_parses_each_of_its_names() {
    for v in CameraWavelengths::ALL {
        assert_eq!(
            render(&["--camera-wavelengths", v.name()]).camera_wavelengths,
            v
        );
    }
    for v in WavelengthSampling::ALL {
        assert_eq!(
            render(&["--wavelength-sampling", v.name()]).wavelength_sampling,
            v
        );
    }
    for v in LightWavelengths::ALL {
        assert_eq!(
            render(&["--light-wavelengths", v.name()]).light_wavelengths,
            v
        );
    }
    for v in MisHeuristic::ALL {
        assert_eq!(render(&["--mis", v.name()]).mis, v);
    }
    for v in Tracking::ALL {
        assert_eq!(render(&["--tracking", v.name()]).tracking, v);
    }
    for v in LaneWeighting::ALL {
        assert_eq!(render(&["--lane-weighting", v.name()]).lane_weighting, v);
    }
}

#[test]
fn a_bad_enum_value_fails_listing_the_possible_values() {
    let e = refused(&["render", "s.json", "-o", "x.exr", "--integrator", "nope"]);
    assert_eq!(e.kind(), ClapKind::InvalidValue);
    let m = e.to_string();
    assert!(
        m.contains("invalid value 'nope' for '--integrator <INTEGRATOR>'"),
        "{m}"
    );
    assert!(
        m.contains(
            "[possible values: pt-mono, pt-hero, bdpt-forward, bdpt-backward, bdpt-combined, bdpt-allbins]"
        ),
        "{m}"
    );
    // Names are case-sensitive; the near miss is offered as a tip.
    let m = refused(&["render", "s.json", "-o", "x.exr", "--tracking", "Aware"]).to_string();
    assert!(
        m.contains("[possible values: exponential, max, aware]"),
        "{m}"
    );
    assert!(m.contains("a similar value exists: 'aware'"), "{m}");
    let m = refused(&["gmm", "fit", "a.bfc", "-o", "m.json", "--method", "vb"]).to_string();
    assert!(m.contains("[possible values: em, bayes]"), "{m}");
}

#[test]
fn possible_values_carry_the_variants_doc_comments() {
    let values = |path: &[&str], long| {
        argument(path, long)
            .get_possible_values()
            .iter()
            .map(|p| {
                let help = p.get_help().map(ToString::to_string).unwrap_or_default();
                (p.get_name().to_string(), help)
            })
            .collect::<Vec<_>>()
    };
    let tracking = values(&["render"], "tracking");
    assert_eq!(tracking.len(), 3);
    // two doc lines joined, the final period dropped
    assert_eq!(
        tracking[0],
        (
            "exponential".to_string(),
            "Classic sampling by σ̂t of the current wavelength: misses collisions where σ̂t < σ̂s \
             (Mojzík Fig. 10a)"
                .to_string()
        )
    );
    // variants without a doc comment have no help
    assert_eq!(
        values(&["render"], "mis"),
        [
            ("balance".to_string(), String::new()),
            ("power".to_string(), String::new())
        ]
    );
    let methods = values(&["gmm", "eval"], "method");
    assert_eq!(
        methods[0],
        ("em".into(), "Weighted expectation–maximisation".into())
    );
}

/// The CLI's name of every variant of `T` is its serde name (configs and command line agree).
fn names_are_serde_names<T>()
where
    T: Choice + serde::Serialize + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug,
{
    assert!(!T::all().is_empty());
    for &v in T::all() {
        assert_eq!(serde_json::to_value(v).unwrap(), v.name());
        assert_eq!(serde_json::from_value::<T>(v.name().into()).unwrap(), v);
    }
}

#[test]
fn command_line_names_are_the_serde_names() {
    names_are_serde_names::<IntegratorKind>();
    names_are_serde_names::<CameraWavelengths>();
    names_are_serde_names::<WavelengthSampling>();
    names_are_serde_names::<LightWavelengths>();
    names_are_serde_names::<MisHeuristic>();
    names_are_serde_names::<Tracking>();
    names_are_serde_names::<LaneWeighting>();
    names_are_serde_names::<FitMethod>();
}

#[test]
fn set_arguments_parse_into_dot_paths_and_json() {
    let a = render(&[
        "--set",
        "media.dye.fluorescence.concentration=0",
        "--set",
        r#"camera.sensor={"band":[300,380]}"#,
        "--set",
        r#"name="a=b""#,
    ]);
    assert_eq!(a.set.len(), 3);
    let sets = parse_sets(&a.set).unwrap();
    assert_eq!(
        sets,
        [
            (
                "media.dye.fluorescence.concentration".to_string(),
                serde_json::json!(0)
            ),
            (
                "camera.sensor".to_string(),
                serde_json::json!({"band": [300, 380]})
            ),
            ("name".to_string(), serde_json::json!("a=b")),
        ]
    );
}

#[test]
fn bad_set_arguments_are_input_errors_naming_the_argument() {
    let cases = [
        ("concentration", "expected PATH=JSON"),
        ("=1", "'' is not a dot path of object keys"),
        ("a..b=1", "'a..b' is not a dot path of object keys"),
        ("a.=1", "is not a dot path"),
        ("a.b=zero", "the value is not JSON"),
        ("a.b=", "the value is not JSON"),
    ];
    for (arg, expected) in cases {
        let e = parse_sets(&["ok=1".to_string(), arg.to_string()]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Input, "{arg}");
        assert!(e.message.starts_with(&format!("--set '{arg}': ")), "{e}");
        assert!(e.message.contains(expected), "{arg}: {e}");
    }
}

#[test]
fn a_typical_render_parses_into_its_arguments() {
    let a = render(&[
        "--integrator",
        "bdpt-forward",
        "--spp",
        "64",
        "--seed",
        "3",
        "--threads",
        "2",
        "--max-depth",
        "12",
        "--png",
        "out.png",
        "--exposure=-1.5",
        "--camera-wavelengths",
        "cmf",
        "--light-wavelengths",
        "uniform",
        "--mis",
        "power",
        "--bin-width",
        "10",
        "--tracking",
        "max",
        "--lane-weighting",
        "hero",
        "--rr-depth",
        "5",
        "--spectral",
        "16",
        "--quiet",
    ]);
    assert_eq!(a.scene, Path::new("scene.json"));
    assert_eq!(a.output, Path::new("out.exr"));
    assert_eq!(a.integrator, IntegratorKind::BdptForward);
    assert_eq!((a.spp, a.seed, a.threads), (64, 3, Some(2)));
    assert_eq!(
        (&a.png, a.exposure),
        (&Some(PathBuf::from("out.png")), -1.5)
    );
    assert_eq!((a.spectral, &a.spectral_output), (Some(16), &None));
    assert!(a.quiet);
    let expected = IntegratorOptions {
        max_depth: 12,
        camera_wavelengths: CameraWavelengths::Cmf,
        light_wavelengths: LightWavelengths::Uniform,
        mis: MisHeuristic::Power,
        bin_width: 10.0,
        tracking: Tracking::Max,
        lane_weighting: LaneWeighting::Hero,
        rr_depth: Some(5),
        ..IntegratorOptions::default()
    };
    assert_eq!(a.options(), expected);
}

#[test]
fn render_sample_ranges_and_their_conflicts() {
    let a = render(&["--samples", "4..8"]);
    assert_eq!((a.samples, a.sample_range()), (Some((4, 8)), (4, 8)));
    let base = ["render", "s.json", "-o", "x.exr", "--samples", "4..8"];
    let with = |extra: &[&'static str]| [&base[..], extra].concat();
    assert_eq!(
        refused(&with(&["--spp", "4"])).kind(),
        ClapKind::ArgumentConflict
    );
    assert_eq!(
        refused(&with(&["--time-limit", "1"])).kind(),
        ClapKind::ArgumentConflict
    );
    assert_eq!(
        refused(&["render", "s.json", "-o", "x.exr", "--samples", "8"]).kind(),
        ClapKind::ValueValidation
    );
    // --spectral-output needs --spectral; -o is required
    let e = refused(&[
        "render",
        "s.json",
        "-o",
        "x.exr",
        "--spectral-output",
        "s.exr",
    ]);
    assert_eq!(e.kind(), ClapKind::MissingRequiredArgument);
    let e = refused(&["render", "s.json"]);
    assert_eq!(e.kind(), ClapKind::MissingRequiredArgument);
    assert!(e.to_string().contains("--output <OUTPUT>"), "{e}");
}
