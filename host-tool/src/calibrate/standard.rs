//! Reference standards: a Lambertian diffuser of reflectance factor R (f = R/pi), or a
//! certified table of reflectance factor per geometry, interpolated linearly.
//!
//! Table text (CSV, `#` comments, header optional):
//!
//! ```text
//! # sintered PTFE, certificate 1234, 632.8 nm
//! theta_i,theta_r,reflectance_factor
//! 0,-80,0.962
//! 0,0,0.991
//! ...
//! ```
//!
//! Angles in degrees, theta_r signed (positive on the specular side). Rows are grouped by
//! theta_i: within a group the factor is linear in theta_r; between the two groups that
//! bracket a reading's theta_i it is linear in theta_i. A geometry outside the table's
//! range (or a theta_i between groups that do not both cover its theta_r) is refused,
//! never extrapolated.

use std::fmt;
use std::path::Path;

use super::error::CalibrationError;

/// Two angles closer than this (degrees) are the same table angle.
pub const ANGLE_TOL_DEG: f64 = 1e-9;

/// Largest certified table read (bytes).
pub const MAX_TABLE_BYTES: u64 = 16 << 20;

/// Why a standard's spec (`lambertian:R`, `table:FILE`) was refused. `Display` is one
/// line without the spec itself, which the caller names with its own option.
#[derive(Debug, Clone, PartialEq)]
pub enum SpecError {
    /// The spec: its form, its number, its file or its table.
    Spec(String),
    /// The relative uncertainty given with it.
    Uncertainty(CalibrationError),
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpecError::Spec(m) => f.write_str(m),
            SpecError::Uncertainty(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for SpecError {}

/// A reference standard and the relative standard uncertainty of its stated
/// reflectance factor (a scale error common to all readings: it adds to u(K)/K).
#[derive(Debug, Clone, PartialEq)]
pub struct Standard {
    kind: Kind,
    relative_uncertainty: f64,
}

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Lambertian(f64),
    Table(ReflectanceTable),
}

/// A certified table of reflectance factor per (theta_i, theta_r).
#[derive(Debug, Clone, PartialEq)]
pub struct ReflectanceTable {
    /// The table's name (its file name), for reports.
    pub name: String,
    /// Rows grouped by theta_i (ascending), each group's (theta_r, factor) ascending in theta_r.
    groups: Vec<(f64, Vec<(f64, f64)>)>,
}

impl Standard {
    /// A near-Lambertian diffuser of reflectance factor `r` in (0, 1] (f = r/pi in 1/sr).
    pub fn lambertian(r: f64) -> Result<Self, CalibrationError> {
        if !(r.is_finite() && r > 0.0 && r <= 1.0) {
            return Err(CalibrationError::BadStandard(format!(
                "a Lambertian reflectance factor must be in (0, 1] (got {r})"
            )));
        }
        Ok(Standard {
            kind: Kind::Lambertian(r),
            relative_uncertainty: 0.0,
        })
    }

    /// A certified table, parsed from CSV text (module docs); `name` labels it in reports.
    pub fn table(name: &str, text: &str) -> Result<Self, CalibrationError> {
        Ok(Standard {
            kind: Kind::Table(ReflectanceTable::parse(name, text)?),
            relative_uncertainty: 0.0,
        })
    }

    /// Parses `lambertian:R` (R in (0, 1]) or `table:FILE` (reading FILE, at most
    /// [`MAX_TABLE_BYTES`]), with the relative uncertainty `uncertainty` of its
    /// reflectance factor: the one spelling of a standard every command takes.
    pub fn from_spec(spec: &str, uncertainty: f64) -> Result<Self, SpecError> {
        let bad = |m: String| SpecError::Spec(m);
        let s = match spec.split_once(':') {
            Some(("lambertian", r)) => {
                let r: f64 = r
                    .trim()
                    .parse()
                    .map_err(|_| bad(format!("'{r}' is not a number")))?;
                Standard::lambertian(r).map_err(|e| bad(e.to_string()))?
            }
            Some(("table", file)) if !file.is_empty() => {
                let path = Path::new(file);
                let len = std::fs::metadata(path)
                    .map_err(|e| bad(format!("cannot read {file}: {e}")))?
                    .len();
                if len > MAX_TABLE_BYTES {
                    return Err(bad(format!(
                        "{file} is larger than {} MiB: not a certificate table",
                        MAX_TABLE_BYTES >> 20
                    )));
                }
                let text = std::fs::read_to_string(path)
                    .map_err(|e| bad(format!("cannot read {file}: {e}")))?;
                Standard::table(file, &text).map_err(|e| bad(e.to_string()))?
            }
            _ => return Err(bad("use lambertian:R or table:FILE".into())),
        };
        s.with_relative_uncertainty(uncertainty)
            .map_err(SpecError::Uncertainty)
    }

    /// The reflectance factor R of a Lambertian standard; `None` for a table.
    pub fn lambertian_factor(&self) -> Option<f64> {
        match &self.kind {
            Kind::Lambertian(r) => Some(*r),
            Kind::Table(_) => None,
        }
    }

    /// Sets the relative standard uncertainty of the stated reflectance factor (e.g.
    /// 0.005 for a certificate's 0.5 %), in [0, 1).
    pub fn with_relative_uncertainty(mut self, u: f64) -> Result<Self, CalibrationError> {
        if !(u.is_finite() && (0.0..1.0).contains(&u)) {
            return Err(CalibrationError::BadStandard(format!(
                "the relative uncertainty of the reflectance factor must be in [0, 1) (got {u})"
            )));
        }
        self.relative_uncertainty = u;
        Ok(self)
    }

    /// The relative standard uncertainty of the stated reflectance factor.
    pub fn relative_uncertainty(&self) -> f64 {
        self.relative_uncertainty
    }

    /// The standard in the CLI's spelling: `lambertian:R` or `table:NAME`.
    pub fn describe(&self) -> String {
        match &self.kind {
            Kind::Lambertian(r) => format!("lambertian:{r}"),
            Kind::Table(t) => format!("table:{}", t.name),
        }
    }

    /// The stated reflectance factor at a geometry (degrees, theta_r signed).
    /// `reading` numbers the error message (from 1).
    pub fn reflectance_factor(
        &self,
        reading: usize,
        theta_i: f64,
        theta_r: f64,
    ) -> Result<f64, CalibrationError> {
        match &self.kind {
            Kind::Lambertian(r) => Ok(*r),
            Kind::Table(t) => {
                t.at(theta_i, theta_r)
                    .ok_or_else(|| CalibrationError::OutsideTable {
                        reading,
                        theta_i,
                        theta_r,
                        covers: t.covers(),
                    })
            }
        }
    }

    /// The stated reflectance factor at a geometry (degrees, theta_r signed), angles up
    /// to `tol` degrees outside a table taken at its edge; `None` outside.
    pub fn factor_within(&self, theta_i: f64, theta_r: f64, tol: f64) -> Option<f64> {
        match &self.kind {
            Kind::Lambertian(r) => Some(*r),
            Kind::Table(t) => t.at_within(theta_i, theta_r, tol),
        }
    }

    /// The stated BRDF in 1/sr at a geometry: reflectance factor / pi.
    pub fn brdf(
        &self,
        reading: usize,
        theta_i: f64,
        theta_r: f64,
    ) -> Result<f64, CalibrationError> {
        Ok(self.reflectance_factor(reading, theta_i, theta_r)? / std::f64::consts::PI)
    }
}

impl ReflectanceTable {
    /// Parses the table text (module docs). Refuses a bad number, an angle out of range,
    /// a factor <= 0, a duplicated geometry and an empty table, each with its line number.
    pub fn parse(name: &str, text: &str) -> Result<Self, CalibrationError> {
        let bad = |line: usize, m: String| {
            CalibrationError::BadStandard(format!("{name} line {line}: {m}"))
        };
        let mut cols = [0usize, 1, 2];
        let mut rows: Vec<(f64, f64, f64)> = Vec::new();
        let mut seen_data = false;
        for (k, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if !seen_data && fields[0].parse::<f64>().is_err() {
                // The header: find the columns by name.
                for (c, want) in ["theta_i", "theta_r", "reflectance_factor"]
                    .iter()
                    .enumerate()
                {
                    cols[c] = fields.iter().position(|f| f == want).ok_or_else(|| {
                        bad(
                            k + 1,
                            format!("the header has no `{want}` column (found `{line}`)"),
                        )
                    })?;
                }
                seen_data = true;
                continue;
            }
            seen_data = true;
            let mut v = [0.0; 3];
            for (c, &col) in cols.iter().enumerate() {
                let f = fields
                    .get(col)
                    .ok_or_else(|| bad(k + 1, format!("expected at least {} fields", col + 1)))?;
                v[c] = f
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(k + 1, format!("`{f}` is not a finite number")))?;
            }
            let [ti, tr, r] = v;
            if !(0.0..=90.0).contains(&ti) {
                return Err(bad(
                    k + 1,
                    format!("theta_i = {ti} is outside [0, 90] degrees"),
                ));
            }
            if !(-90.0..=90.0).contains(&tr) {
                return Err(bad(
                    k + 1,
                    format!("theta_r = {tr} is outside [-90, 90] degrees"),
                ));
            }
            if r <= 0.0 {
                return Err(bad(k + 1, format!("reflectance factor {r} must be > 0")));
            }
            if rows.iter().any(|&(a, b, _)| {
                (a - ti).abs() <= ANGLE_TOL_DEG && (b - tr).abs() <= ANGLE_TOL_DEG
            }) {
                return Err(bad(
                    k + 1,
                    format!("theta_i = {ti}, theta_r = {tr} is listed twice"),
                ));
            }
            rows.push((ti, tr, r));
        }
        if rows.is_empty() {
            return Err(CalibrationError::BadStandard(format!(
                "{name}: the table has no rows"
            )));
        }
        rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut groups: Vec<(f64, Vec<(f64, f64)>)> = Vec::new();
        for (ti, tr, r) in rows {
            match groups.last_mut() {
                Some((g, v)) if (ti - *g).abs() <= ANGLE_TOL_DEG => v.push((tr, r)),
                _ => groups.push((ti, vec![(tr, r)])),
            }
        }
        Ok(ReflectanceTable {
            name: name.to_string(),
            groups,
        })
    }

    /// The interpolated factor, or `None` outside the table.
    pub fn at(&self, theta_i: f64, theta_r: f64) -> Option<f64> {
        self.at_within(theta_i, theta_r, ANGLE_TOL_DEG)
    }

    /// [`ReflectanceTable::at`] with angles up to `tol` degrees outside the table taken
    /// at its edge (a simulated arm that stops a step past the last tabulated angle).
    pub fn at_within(&self, theta_i: f64, theta_r: f64, tol: f64) -> Option<f64> {
        let g = &self.groups;
        let theta_i = if theta_i < g[0].0 && theta_i >= g[0].0 - tol {
            g[0].0
        } else if theta_i > g[g.len() - 1].0 && theta_i <= g[g.len() - 1].0 + tol {
            g[g.len() - 1].0
        } else {
            theta_i
        };
        let in_row = |row: &[(f64, f64)]| -> Option<f64> {
            let (first, last) = (row[0], row[row.len() - 1]);
            if theta_r < first.0 - tol || theta_r > last.0 + tol {
                return None;
            }
            if row.len() == 1 {
                return Some(first.1);
            }
            let j = row
                .partition_point(|p| p.0 < theta_r)
                .clamp(1, row.len() - 1);
            let ((x0, y0), (x1, y1)) = (row[j - 1], row[j]);
            let t = ((theta_r - x0) / (x1 - x0)).clamp(0.0, 1.0);
            Some(y0 + (y1 - y0) * t)
        };
        if let Some((_, row)) = g.iter().find(|(t, _)| (t - theta_i).abs() <= ANGLE_TOL_DEG) {
            return in_row(row);
        }
        let j = g.partition_point(|(t, _)| *t < theta_i);
        if j == 0 || j == g.len() {
            return None;
        }
        let ((t0, r0), (t1, r1)) = (&g[j - 1], &g[j]);
        let (a, b) = (in_row(r0)?, in_row(r1)?);
        Some(a + (b - a) * (theta_i - t0) / (t1 - t0))
    }

    /// What the table covers, in words (for the refusal message).
    pub fn covers(&self) -> String {
        let parts: Vec<String> = self
            .groups
            .iter()
            .map(|(t, row)| {
                format!(
                    "theta_i {t}: theta_r {}..{}",
                    row[0].0,
                    row[row.len() - 1].0
                )
            })
            .collect();
        parts.join("; ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PTFE: &str = "# test table\ntheta_i,theta_r,reflectance_factor\n\
        0,-60,0.90\n0,0,1.00\n0,60,0.90\n40,-60,0.80\n40,0,0.98\n40,60,1.10\n";

    #[test]
    fn table_interpolates_linearly_in_both_angles() {
        let s = Standard::table("ptfe.csv", PTFE).unwrap();
        let rf = |ti, tr| s.reflectance_factor(1, ti, tr).unwrap();
        assert_eq!(rf(0.0, 0.0), 1.0);
        assert!((rf(0.0, 30.0) - 0.95).abs() < 1e-12);
        assert!((rf(40.0, 30.0) - 1.04).abs() < 1e-12);
        // Halfway in theta_i between 0.95 and 1.04.
        assert!((rf(20.0, 30.0) - 0.995).abs() < 1e-12);
        assert!((s.brdf(1, 0.0, 0.0).unwrap() - 1.0 / std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(s.describe(), "table:ptfe.csv");
    }

    #[test]
    fn table_refuses_outside_its_range() {
        let s = Standard::table("ptfe.csv", PTFE).unwrap();
        for (ti, tr) in [(0.0, 70.0), (50.0, 0.0), (20.0, -61.0)] {
            let e = s.reflectance_factor(3, ti, tr).unwrap_err();
            assert!(
                matches!(e, CalibrationError::OutsideTable { reading: 3, .. }),
                "{e}"
            );
            assert!(e.to_string().contains("theta_i 0: theta_r -60..60"), "{e}");
        }
        // A simulated arm a step past the edge reads the edge within the tolerance only.
        assert_eq!(s.factor_within(0.0, 60.04, 0.05), Some(0.90));
        assert_eq!(s.factor_within(40.03, -60.0, 0.05), Some(0.80));
        assert_eq!(s.factor_within(0.0, 60.1, 0.05), None);
        assert_eq!(s.factor_within(40.1, 0.0, 0.05), None);
    }

    #[test]
    fn table_without_header_and_single_incidence() {
        let s = Standard::table("t", "8,-10,0.5\n8,10,0.7\n").unwrap();
        assert!((s.reflectance_factor(1, 8.0, 0.0).unwrap() - 0.6).abs() < 1e-12);
        assert!(s.reflectance_factor(1, 9.0, 0.0).is_err());
    }

    #[test]
    fn bad_tables_and_factors_are_refused_with_the_line() {
        for (text, want) in [
            ("theta_i,theta_r,rf\n", "no `reflectance_factor` column"),
            ("0,0,x\n", "line 1: `x` is not a finite number"),
            (
                "0,0,0.9\n0,0,0.8\n",
                "line 2: theta_i = 0, theta_r = 0 is listed twice",
            ),
            ("0,95,0.9\n", "theta_r = 95 is outside"),
            ("0,0,0\n", "must be > 0"),
            ("# nothing\n", "no rows"),
            ("0,0\n", "expected at least 3 fields"),
        ] {
            let e = Standard::table("t.csv", text).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        assert!(Standard::lambertian(0.0).is_err());
        assert!(Standard::lambertian(1.2).is_err());
        assert!(Standard::lambertian(f64::NAN).is_err());
        assert!(
            Standard::lambertian(0.99)
                .unwrap()
                .with_relative_uncertainty(1.5)
                .is_err()
        );
        assert_eq!(
            Standard::lambertian(0.99).unwrap().describe(),
            "lambertian:0.99"
        );
    }

    #[test]
    fn a_spec_names_a_lambertian_or_a_table_file() {
        let s = Standard::from_spec("lambertian: 0.98", 0.005).unwrap();
        assert_eq!(s.lambertian_factor(), Some(0.98));
        assert_eq!(s.relative_uncertainty(), 0.005);
        let dir = std::env::temp_dir().join(format!("gonio-spec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("ptfe.csv");
        std::fs::write(&file, PTFE).unwrap();
        let t = Standard::from_spec(&format!("table:{}", file.display()), 0.0).unwrap();
        assert_eq!(t.lambertian_factor(), None);
        assert_eq!(t.reflectance_factor(1, 0.0, 0.0).unwrap(), 1.0);
        let _ = std::fs::remove_dir_all(&dir);
        for (spec, want) in [
            ("lambertian:x", "'x' is not a number"),
            ("lambertian:1.5", "must be in (0, 1]"),
            ("table:", "use lambertian:R or table:FILE"),
            ("ptfe", "use lambertian:R or table:FILE"),
            ("table:/nonexistent/t.csv", "cannot read /nonexistent/t.csv"),
        ] {
            let e = Standard::from_spec(spec, 0.0).unwrap_err();
            assert!(matches!(e, SpecError::Spec(_)), "{spec}: {e:?}");
            assert!(e.to_string().contains(want), "{spec}: {e}");
        }
        let e = Standard::from_spec("lambertian:0.9", 1.5).unwrap_err();
        assert!(matches!(e, SpecError::Uncertainty(_)), "{e:?}");
    }
}
