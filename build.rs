//! Embeds the CIE illuminant tables of `data/spectra/illuminants/` into the binary
//! (`spectrum::illuminants`), so that `stokes gmm eval` finds them wherever it runs.

use std::path::Path;

fn main() {
    let dir = Path::new("data/spectra/illuminants");
    println!("cargo::rerun-if-changed={}", dir.display());
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("data/spectra/illuminants")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".csv"))
        .collect();
    names.sort();
    let mut code = String::from("&[\n");
    for n in &names {
        code += &format!(
            "    ({n:?}, include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/data/spectra/illuminants/{n}\"))),\n"
        );
    }
    code += "]\n";
    let out = Path::new(&std::env::var("OUT_DIR").unwrap()).join("illuminants.rs");
    std::fs::write(out, code).expect("writing the illuminant table");
}
