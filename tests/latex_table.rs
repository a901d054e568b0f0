//! The LaTeX summary table (`figures/summary-table.tex`): escaping, number format and bolding,
//! the table of a stored run with two budget modes checked against its `summary.json`, no table
//! without metrics, and the table through `pdflatex` (when installed).

mod common;

use common::temp_dir;
use std::path::{Path, PathBuf};
use std::process::Command;
use stokes::ErrorKind;
use stokes::experiment::latex_table::{
    Block, TABLE_FILE, Table, escape, number, write_summary_table,
};
use stokes::experiment::record::SummaryEntry;

/// The run folder named by `results/<experiment>/latest`.
fn stored_run(experiment: &str) -> PathBuf {
    let e = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("results")
        .join(experiment);
    let latest = std::fs::read_to_string(e.join("latest")).unwrap();
    e.join(latest.trim())
}

/// A copy of a stored run's `run.json` and `metrics.csv` (and `summary.json`) in a new folder.
fn copy_run(experiment: &str, tag: &str) -> (PathBuf, PathBuf) {
    let src = stored_run(experiment);
    let d = temp_dir(tag);
    for f in ["run.json", "metrics.csv", "summary.json"] {
        std::fs::copy(src.join(f), d.join(f)).unwrap();
    }
    (src, d)
}

fn on_path(tool: &str) -> bool {
    Command::new(tool).arg("--version").output().is_ok()
}

#[test]
fn escape_latex_special_characters() {
    assert_eq!(escape("pt-mono"), "pt-mono");
    assert_eq!(
        escape(r"a_b&c%d#e$f{g}h~i^j\k"),
        r"a\_b\&c\%d\#e\$f\{g\}h\textasciitilde{}i\textasciicircum{}j\textbackslash{}k"
    );
    assert_eq!(escape("x<y>z"), r"x\textless{}y\textgreater{}z");
    assert_eq!(escape("two\nlines"), "two lines");
}

#[test]
fn numbers_have_one_decimal_and_a_true_minus() {
    assert_eq!(number(Some(33.46)), "33.5");
    assert_eq!(number(Some(7.0)), "7.0");
    assert_eq!(number(Some(-1.04)), "$-$1.0");
    assert_eq!(number(Some(-0.04)), "0.0");
    assert_eq!(number(Some(f64::INFINITY)), r"$\infty$");
    assert_eq!(number(Some(f64::NAN)), "--");
    assert_eq!(number(None), "--");
}

fn block(label: &str, rows: &[(&str, [Option<f64>; 3])]) -> Block {
    Block {
        label: label.into(),
        repeats: (3, 3),
        rows: rows
            .iter()
            .map(|(n, v)| (n.to_string(), v.to_vec()))
            .collect(),
    }
}

/// The body line of `variant` in the text of a table.
fn line<'a>(tex: &'a str, variant: &str) -> &'a str {
    tex.lines()
        .find(|l| l.starts_with(&format!("{variant} &")))
        .unwrap_or_else(|| panic!("no row {variant:?} in\n{tex}"))
}

#[test]
fn best_of_each_column_is_bold_and_ties_are_all_bold() {
    let t = Table {
        experiment: "walls_test".into(),
        regions: vec!["all".into(), "floor".into(), "left_wall".into()],
        blocks: vec![block(
            "equal time, 40 s",
            &[
                // The first column ties on the printed value (21.54 and 21.46 both read 21.5).
                ("a", [Some(21.54), Some(-3.0), None]),
                ("b_c", [Some(21.46), Some(-2.96), Some(f64::NAN)]),
                ("d", [Some(10.0), Some(-20.0), Some(5.0)]),
            ],
        )],
    };
    let tex = t.to_tex();
    assert_eq!(
        line(&tex, "a"),
        r"a & \textbf{21.5} & \textbf{$-$3.0} & -- \\"
    );
    assert_eq!(
        line(&tex, r"b\_c"),
        r"b\_c & \textbf{21.5} & \textbf{$-$3.0} & -- \\"
    );
    assert_eq!(line(&tex, "d"), r"d & 10.0 & $-$20.0 & \textbf{5.0} \\");
    assert!(tex.contains("\\begin{tabular}{l r r r}\n\\toprule\n"));
    assert!(tex.contains(r" & \multicolumn{3}{c}{SNR (dB)} \\"));
    assert!(tex.contains(r"variant & all & floor & left\_wall \\"));
    assert!(tex.ends_with("\\bottomrule\n\\end{tabular}\n"));
    assert_eq!(tex.matches("\\midrule").count(), 1);
    // One mode: no block heading, the budget is in the caption comment.
    assert!(!tex.contains(r"\emph"));
    let caption = tex.lines().find(|l| l.starts_with("% Caption:")).unwrap();
    assert!(caption.contains("walls_test"), "{caption}");
    assert!(
        caption.contains("equal time, 40 s, mean over 3 repeats"),
        "{caption}"
    );
}

#[test]
fn each_mode_is_a_block_with_its_own_best() {
    let t = Table {
        experiment: "two modes".into(),
        regions: vec!["all".into(), "floor".into(), "left".into()],
        blocks: vec![
            block(
                "equal spp, 128 spp",
                &[
                    ("a", [Some(1.0), Some(2.0), Some(3.0)]),
                    ("b", [Some(0.0); 3]),
                ],
            ),
            block(
                "equal time, 40 s",
                &[
                    ("a", [Some(0.0); 3]),
                    ("b", [Some(1.0), Some(2.0), Some(3.0)]),
                ],
            ),
        ],
    };
    let tex = t.to_tex();
    assert_eq!(tex.matches("\\midrule").count(), 2);
    let spp = tex
        .find(r"\multicolumn{4}{l}{\emph{equal spp, 128 spp}} \\")
        .unwrap();
    let time = tex
        .find(r"\multicolumn{4}{l}{\emph{equal time, 40 s}} \\")
        .unwrap();
    assert!(spp < time);
    let (first, second) = tex.split_at(time);
    assert_eq!(
        line(first, "a"),
        r"a & \textbf{1.0} & \textbf{2.0} & \textbf{3.0} \\"
    );
    assert_eq!(line(second, "a"), r"a & 0.0 & 0.0 & 0.0 \\");
    assert_eq!(
        line(second, "b"),
        r"b & \textbf{1.0} & \textbf{2.0} & \textbf{3.0} \\"
    );
}

/// The cells of the body rows: variant → printed values without `\textbf`.
fn cells(block: &str) -> Vec<(String, Vec<String>)> {
    block
        .lines()
        .filter(|l| l.ends_with(r" \\") && !l.starts_with(' ') && !l.starts_with('\\'))
        .filter(|l| !l.starts_with("variant &"))
        .map(|l| {
            let mut f = l.trim_end_matches(r" \\").split(" & ").map(|c| {
                c.trim_start_matches(r"\textbf{")
                    .trim_end_matches('}')
                    .to_string()
            });
            let name = f.next().unwrap();
            (name, f.collect())
        })
        .collect()
}

#[test]
fn table_of_a_stored_run_matches_its_summary_json() {
    let (src, d) = copy_run("walls-wavelength-sampling", "stored");
    let p = write_summary_table(&d)
        .unwrap()
        .expect("the run has metrics");
    assert_eq!(p, d.join("figures").join(TABLE_FILE));
    let tex = std::fs::read_to_string(&p).unwrap();
    // all + 6 regions; one block per mode, in run.json's order.
    assert!(tex.contains(r"\begin{tabular}{l r r r r r r r}"), "{tex}");
    assert!(tex.contains(r"variant & all & floor & ceiling & back & left & right & light \\"));
    let time = tex.find(r"\emph{equal time, 40 s}").expect("a time block");
    let spp = tex
        .find(r"\emph{equal spp, 128 spp}")
        .expect("an spp block");
    assert!(spp < time);
    for (b, mode, budget) in [
        (&tex[spp..time], "spp", 128.0),
        (&tex[time..], "time", 40.0),
    ] {
        let summary: Vec<SummaryEntry> =
            serde_json::from_str(&std::fs::read_to_string(src.join("summary.json")).unwrap())
                .unwrap();
        let rows = cells(b);
        assert!(!rows.is_empty(), "{b}");
        let regions = ["all", "floor", "ceiling", "back", "left", "right", "light"];
        for (variant, values) in &rows {
            for (region, v) in regions.iter().zip(values) {
                let e = summary
                    .iter()
                    .find(|e| {
                        &e.variant == variant
                            && e.mode == mode
                            && e.budget == budget
                            && e.region == *region
                    })
                    .unwrap_or_else(|| panic!("{variant} {mode} {region} not in summary.json"));
                assert_eq!(*v, number(Some(e.snr_db.mean)), "{variant} {mode} {region}");
            }
        }
        // Every column of the block has a bold best.
        let body: Vec<&str> = b
            .lines()
            .filter(|l| rows.iter().any(|r| l.starts_with(&format!("{} &", r.0))))
            .collect();
        for c in 1..=regions.len() {
            assert!(
                body.iter()
                    .any(|l| l.split(" & ").nth(c).unwrap().starts_with(r"\textbf{")),
                "column {c} of the {mode} block has no bold value:\n{b}"
            );
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn no_metrics_no_table() {
    let (_, d) = copy_run("walls-integrators", "nometrics");
    std::fs::remove_file(d.join("metrics.csv")).unwrap();
    assert!(write_summary_table(&d).unwrap().is_none());
    // A run without a reference writes only the header.
    let header = std::fs::read_to_string(stored_run("walls-integrators").join("metrics.csv"))
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string();
    std::fs::write(d.join("metrics.csv"), header + "\n").unwrap();
    assert!(write_summary_table(&d).unwrap().is_none());
    assert!(!d.join("figures").join(TABLE_FILE).exists());
    // A malformed metrics.csv is an input error naming the file.
    std::fs::write(d.join("metrics.csv"), "not,a,header\n").unwrap();
    let e = write_summary_table(&d).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Input);
    assert!(e.message.contains("metrics.csv"), "{}", e.message);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn table_compiles_with_pdflatex() {
    if !on_path("pdflatex") {
        eprintln!("skipped: pdflatex is not installed, the table was not compiled");
        return;
    }
    let (_, d) = copy_run("walls-wavelength-sampling", "pdflatex");
    write_summary_table(&d).unwrap().unwrap();
    let fig = d.join("figures");
    let odd = Table {
        experiment: r"odd_names & 100% {#1}".into(),
        regions: vec!["all".into(), r"a_b&c%d#e$f{g}h~i^j\k".into()],
        blocks: vec![
            Block {
                label: "equal spp, 8 spp".into(),
                repeats: (1, 2),
                rows: vec![("x_y".into(), vec![Some(-1.25), None])],
            },
            Block {
                label: "equal time, 2.5 s".into(),
                repeats: (1, 1),
                rows: vec![("x_y".into(), vec![Some(f64::INFINITY), Some(3.0)])],
            },
        ],
    };
    std::fs::write(fig.join("odd.tex"), odd.to_tex()).unwrap();
    std::fs::write(
        fig.join("paper.tex"),
        "\\documentclass{article}\n\\usepackage{booktabs}\n\\begin{document}\n\
         \\begin{table}\\centering\\input{summary-table.tex}\\caption{SNR}\\end{table}\n\
         \\begin{table}\\centering\\input{odd.tex}\\caption{Odd names}\\end{table}\n\
         \\end{document}\n",
    )
    .unwrap();
    let out = Command::new("pdflatex")
        .args(["-interaction=nonstopmode", "-halt-on-error", "paper.tex"])
        .current_dir(&fig)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pdflatex failed:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(fig.join("paper.pdf").is_file());
    std::fs::remove_dir_all(&d).unwrap();
}
