//! The `# brdf:` header line: which units a sweep's brdf (and std) column holds, the
//! instrument's `relative` units or the absolute `1/sr`; a file without it is relative.

use std::fmt;

/// The metadata key of the line (`# brdf: 1/sr`).
pub const BRDF_KEY: &str = "brdf";

/// The units of a sweep's brdf column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum BrdfUnits {
    /// The instrument's relative units (K f of V = K f cos(theta_r)): what a capture
    /// writes, and what a file without a `# brdf:` line holds.
    #[default]
    #[serde(rename = "relative")]
    Relative,
    /// The BRDF in 1/sr (after `gonio convert`, or imported from MERL).
    #[serde(rename = "1/sr")]
    PerSr,
}

impl BrdfUnits {
    /// The word of the header line: `relative` or `1/sr`.
    pub fn word(self) -> &'static str {
        match self {
            BrdfUnits::Relative => "relative",
            BrdfUnits::PerSr => "1/sr",
        }
    }

    /// The whole header line, with its newline.
    pub fn header_line(self) -> String {
        format!("# {BRDF_KEY}: {}\n", self.word())
    }

    /// Parses the value of a `# brdf:` line: `relative`, or `1/sr` (also `sr^-1`,
    /// `sr-1`, `per sr`; case and spaces ignored). Anything else is refused with the
    /// words accepted, so a file is never read in the wrong units.
    pub fn parse(value: &str) -> Result<Self, String> {
        let v: String = value
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_lowercase();
        match v.as_str() {
            "relative" => Ok(BrdfUnits::Relative),
            "1/sr" | "sr^-1" | "sr-1" | "persr" => Ok(BrdfUnits::PerSr),
            _ => Err(format!(
                "brdf units '{}': gonio knows 'relative' (the instrument's units) and '1/sr'",
                crate::text::escape_line(value, 40)
            )),
        }
    }
}

impl fmt::Display for BrdfUnits {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// Refuses to combine sweeps of different units (`what` says what was tried, e.g.
/// "fit --instrument"): one line naming both.
pub fn refuse_mixed(
    what: &str,
    a: (&std::path::Path, BrdfUnits),
    b: (&str, BrdfUnits),
) -> Result<(), String> {
    if a.1 == b.1 {
        return Ok(());
    }
    Err(format!(
        "{what}: {} holds brdf in {} but {} is in {}: gonio does not mix units (convert with gonio convert first)",
        a.0.display(),
        a.1,
        b.0,
        b.1
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::parse_sweep;

    #[test]
    fn header_words_parse_and_default_to_relative() {
        assert_eq!(BrdfUnits::parse("1/sr"), Ok(BrdfUnits::PerSr));
        assert_eq!(BrdfUnits::parse(" SR^-1 "), Ok(BrdfUnits::PerSr));
        assert_eq!(BrdfUnits::parse("Relative"), Ok(BrdfUnits::Relative));
        let e = BrdfUnits::parse("W/m2").unwrap_err();
        assert!(e.contains("'relative'") && e.contains("'1/sr'"), "{e}");
        let none = parse_sweep(b"theta_i,theta_r,brdf\n0,0,1\n").unwrap();
        assert_eq!(
            (none.declared_brdf_units(), none.brdf_units()),
            (None, BrdfUnits::Relative)
        );
        let abs = parse_sweep(b"# brdf: 1/sr\ntheta_i,theta_r,brdf\n0,0,1\n").unwrap();
        assert_eq!(abs.brdf_units(), BrdfUnits::PerSr);
        assert_eq!(BrdfUnits::PerSr.header_line(), "# brdf: 1/sr\n");
    }

    #[test]
    fn an_unknown_unit_is_refused_with_its_line() {
        let (line, msg) =
            parse_sweep(b"# units: degrees\n# brdf: counts\ntheta_i,theta_r,brdf\n0,0,1\n")
                .unwrap_err();
        assert_eq!(line, 2);
        assert!(msg.contains("brdf units 'counts'"), "{msg}");
    }

    #[test]
    fn a_capture_says_relative_and_a_converted_file_is_not_resumed() {
        use crate::sweep_file::{Header, SweepWriter, read_sweep};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        let header = Header {
            device: "sim".into(),
            plan: "paper".into(),
            settings: "samples=4".into(),
            points: vec![(0.0, 10.0), (0.0, 20.0)],
            sample: None,
        };
        drop(SweepWriter::create(&path, &header, false).unwrap());
        assert_eq!(
            read_sweep(&path).unwrap().declared_brdf_units(),
            Some(BrdfUnits::Relative)
        );
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text.replace("# brdf: relative", "# brdf: 1/sr")).unwrap();
        let e = SweepWriter::resume(&path).err().unwrap().to_string();
        assert!(e.contains("its brdf is in 1/sr (a converted file)"), "{e}");
    }

    #[test]
    fn mixing_is_refused_naming_both() {
        let p = std::path::Path::new("a.csv");
        assert!(refuse_mixed("x", (p, BrdfUnits::PerSr), ("b", BrdfUnits::PerSr)).is_ok());
        let e =
            refuse_mixed("fit", (p, BrdfUnits::PerSr), ("b.csv", BrdfUnits::Relative)).unwrap_err();
        assert!(
            e.contains("a.csv holds brdf in 1/sr but b.csv is in relative"),
            "{e}"
        );
    }
}
