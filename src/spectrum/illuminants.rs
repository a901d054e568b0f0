//! The CIE standard illuminants of `data/spectra/illuminants/` (A, B, C, D50–D75, E, FL1–FL12,
//! FL3.x, HP1–5, LED-*, ID50/ID65, ISO 7589), compiled into the binary by `build.rs`: the tables
//! `stokes gmm eval` compares colours under, found wherever stokes runs.

/// (file name, "wavelength, value" CSV text) of every illuminant, sorted by file name.
pub static EMBEDDED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/illuminants.rs"));

#[cfg(test)]
mod tests {
    #[test]
    fn every_illuminant_is_embedded() {
        assert_eq!(super::EMBEDDED.len(), 59);
        let d65 = super::EMBEDDED
            .iter()
            .find(|(n, _)| *n == "illuminant_D65.csv")
            .unwrap();
        assert!(d65.1.lines().count() > 90);
    }
}
