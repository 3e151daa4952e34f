//! The sweep file's parts: its columns, a row, the status line and its counters, the
//! header written first, and [`SweepFileError`].

use std::fmt;

/// Why a sweep file could not be read or written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SweepFileError {
    /// The file (or the request) is wrong: unreadable, malformed, not a capture file,
    /// or already there without `force`. One line, naming the file.
    Invalid(String),
    /// Writing or syncing failed (disk full, unplugged...). One line, naming the file.
    Io(String),
}

impl fmt::Display for SweepFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SweepFileError::Invalid(m) | SweepFileError::Io(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for SweepFileError {}

/// The `# key:` lines gonio reads or writes (keys in any case); others are kept in
/// [`super::SweepData::meta`] and named by [`super::SweepData::warnings`]: gonio does not read them.
/// The format's own keys, then the measurement's ([`MEASUREMENT_KEYS`], one list for
/// both: a key added there is read here too).
pub const KNOWN_KEYS: [&str; FORMAT_KEYS.len() + MEASUREMENT_KEYS.len()] =
    concat_keys(FORMAT_KEYS, MEASUREMENT_KEYS);

/// The keys of the capture and its reduction (status, plan, units, ...): [`KNOWN_KEYS`]
/// less the measurement's.
const FORMAT_KEYS: [&str; 16] = [
    "status",
    "device",
    "units",
    "brdf",
    "plan",
    "settings",
    "started",
    "points",
    "source",
    "calibration",
    "aperture",
    "offset",
    "out-of-plane",
    "missing",
    "repeats",
    "theta_r",
];

/// The measurement's keys, read and written by [`super::Measurement`] (with `started`
/// as the date's fallback). Here, beside [`KNOWN_KEYS`], which is built from them.
pub const MEASUREMENT_KEYS: [&str; 13] = [
    "wavelength",
    "polarization",
    "polarisation",
    "beam-diameter",
    "solid-angle",
    "nebsdf",
    "signature",
    "sample",
    "operator",
    "date",
    "temperature",
    "role",
    "of",
];

/// `a` then `b`, at compile time.
const fn concat_keys<const A: usize, const B: usize, const C: usize>(
    a: [&'static str; A],
    b: [&'static str; B],
) -> [&'static str; C] {
    assert!(A + B == C);
    let mut out = [""; C];
    let mut i = 0;
    while i < C {
        out[i] = if i < A { a[i] } else { b[i - A] };
        i += 1;
    }
    out
}

/// Columns the capture writes, in order.
pub const COLUMNS: [&str; 7] = ["theta_i", "theta_r", "brdf", "std", "n", "seq", "t_ms"];

/// One row of a sweep file. Optional columns are `None` when the file lacks them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Incidence angle (degrees).
    pub theta_i: f64,
    /// Signed detector angle (degrees).
    pub theta_r: f64,
    /// BRDF, in the file's [`BrdfUnits`].
    pub brdf: f64,
    /// Standard deviation of one sample.
    pub std: Option<f64>,
    /// Samples averaged.
    pub n: Option<u32>,
    /// Index in the plan.
    pub seq: Option<u32>,
    /// Milliseconds since the sweep started.
    pub t_ms: Option<u64>,
}

impl Row {
    /// A reading with only the three required columns (angles in degrees, theta_r
    /// signed; brdf in the file's units).
    pub fn new(theta_i: f64, theta_r: f64, brdf: f64) -> Self {
        Row {
            theta_i,
            theta_r,
            brdf,
            std: None,
            n: None,
            seq: None,
            t_ms: None,
        }
    }
}

/// One row as the table line every writer writes: theta_i, theta_r, brdf, then those
/// of std, n, seq, t_ms that `optional` names (an empty field where the row has none),
/// each value in its shortest exact form; a brdf of -0 is written `0`.
pub(crate) fn row_line(row: &Row, optional: [bool; 4]) -> String {
    use std::fmt::Write;
    let brdf = if row.brdf == 0.0 { 0.0 } else { row.brdf };
    let mut line = format!("{},{},{brdf}", row.theta_i, row.theta_r);
    let opt = |v: Option<String>| v.unwrap_or_default();
    let cells = [
        opt(row.std.map(|v| v.to_string())),
        opt(row.n.map(|v| v.to_string())),
        opt(row.seq.map(|v| v.to_string())),
        opt(row.t_ms.map(|v| v.to_string())),
    ];
    for (cell, on) in cells.iter().zip(optional) {
        if on {
            let _ = write!(line, ",{cell}");
        }
    }
    line.push('\n');
    line
}

/// Readings of a magnitude outside [`BRDF_MIN`, `BRDF_MAX`] (other than 0) are neither
/// written nor read: the fit works with their logarithms and squares, which over- or
/// underflow there. One range for the capture, the writers and the readers
/// ([`brdf_in_range`]).
pub const BRDF_MIN: f64 = 1e-30;

/// See [`BRDF_MIN`].
pub const BRDF_MAX: f64 = 1e30;

/// The largest angle magnitude a sweep file holds (degrees): no goniometer arm turns
/// further, and a reader refuses what a writer would.
pub const ANGLE_MAX_DEG: f64 = 180.0;

/// Whether `v` is a BRDF reading gonio writes and reads: 0, or a magnitude within
/// [`BRDF_MIN`] to [`BRDF_MAX`] (relative or 1/sr).
pub fn brdf_in_range(v: f64) -> bool {
    v == 0.0 || (BRDF_MIN..=BRDF_MAX).contains(&v.abs())
}

/// Why `row` could not be read back as written, or `None`: angles (degrees) not finite
/// or beyond [`ANGLE_MAX_DEG`], a brdf outside [`brdf_in_range`], a std that is
/// negative, not finite or beyond [`BRDF_MAX`]. The writer refuses such a row, the
/// capture rejects (and counts) such a reading, the reader refuses such a line.
pub fn row_problem(row: &Row) -> Option<String> {
    use brdf_core::error::Short;
    for (name, a) in [("theta_i", row.theta_i), ("theta_r", row.theta_r)] {
        if !(a.is_finite() && a.abs() <= ANGLE_MAX_DEG) {
            return Some(format!(
                "{name} {} is not an angle in degrees (finite, at most {ANGLE_MAX_DEG} in magnitude)",
                Short(a)
            ));
        }
    }
    if !(row.brdf.is_finite() && brdf_in_range(row.brdf)) {
        return Some(format!(
            "brdf {} (theta_i {}, theta_r {}) is outside the magnitudes gonio fits ({BRDF_MIN:e} to {BRDF_MAX:e}, or 0): rescale the readings",
            Short(row.brdf),
            row.theta_i,
            row.theta_r
        ));
    }
    if let Some(s) = row.std
        && !(s.is_finite() && (0.0..=BRDF_MAX).contains(&s))
    {
        return Some(format!(
            "std {} (theta_i {}, theta_r {}) is not a standard deviation gonio reads (0 to {BRDF_MAX:e})",
            Short(s),
            row.theta_i,
            row.theta_r
        ));
    }
    None
}

/// Why a metadata value could not be written as one `# key: value` line that reads
/// back the same, or `None`: it holds a line break or another control character
/// (`plan='paper\n# brdf: 1/sr'` would add a line the fit reads).
pub fn meta_problem(key: &str, value: &str) -> Option<String> {
    value.chars().any(char::is_control).then(|| {
        format!(
            "the {key} '{}' holds a line break or control character: metadata values are one line",
            crate::text::escape_line(value, 40)
        )
    })
}

/// How a capture ended, as the status line says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepStatus {
    /// Still running, or the process died.
    Running,
    /// Every point measured.
    Complete,
    /// Stopped by the user (Ctrl-C); `--resume` continues.
    Interrupted,
    /// Stopped by an error; `--resume` continues.
    Failed,
    /// Ended early because the fit's parameters met the capture's `--until` targets;
    /// the plan points not measured are missing as intended (`--resume` measures them).
    Until,
    /// A sequential plan spent its `--budget` of readings before any `--until` target
    /// was met; its other candidate points are missing as intended.
    Budget,
}

impl SweepStatus {
    /// The word in the status line.
    pub fn word(self) -> &'static str {
        match self {
            SweepStatus::Running => "running",
            SweepStatus::Complete => "complete",
            SweepStatus::Interrupted => "interrupted",
            SweepStatus::Failed => "failed",
            SweepStatus::Until => "until",
            SweepStatus::Budget => "budget",
        }
    }
}

/// The counters in the status line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Rows in the file.
    pub readings: u64,
    /// Plan points without a row.
    pub missing: u64,
    /// Readings the device sent that never arrived (sequence gaps seen live).
    pub gaps: u64,
    /// Frames dropped on the way in (CRC, COBS, length, undecodable).
    pub dropped: u64,
    /// Times the device went quiet for longer than the event timeout.
    pub timeouts: u64,
    /// Readings that arrived and failed the capture's checks (a value or std not
    /// finite, angles away from their plan point, a seq outside the sweep): not
    /// written, their points measured again.
    pub rejected: u64,
}

pub(crate) const STATUS_PREFIX: &str = "# status: ";

/// The status line; `with_rejected` false keeps the width of files written before the
/// `rejected` counter existed (a resumed old file is rewritten in place).
pub(crate) fn status_line(status: SweepStatus, c: &Counters, with_rejected: bool) -> String {
    // Fixed width: 7 digits per counter, so the line can be rewritten in place.
    let rejected = if with_rejected {
        format!(" rejected={:07}", c.rejected.min(9_999_999))
    } else {
        String::new()
    };
    format!(
        "{STATUS_PREFIX}{:<12} readings={:07} missing={:07} gaps={:07} dropped={:07} timeouts={:07}{rejected}\n",
        status.word(),
        c.readings.min(9_999_999),
        c.missing.min(9_999_999),
        c.gaps.min(9_999_999),
        c.dropped.min(9_999_999),
        c.timeouts.min(9_999_999)
    )
}

/// Metadata of a new sweep file.
#[derive(Debug, Clone)]
pub struct Header {
    /// Device description (board, firmware, protocol).
    pub device: String,
    /// Plan description (`paper`, `custom ...`, `adaptive ...`, `file.toml`).
    pub plan: String,
    /// Per-point settings, `key=value` words.
    pub settings: String,
    /// What is measured, where the capture knows it (a simulated device's material):
    /// the `# sample:` line; `--resume` refuses another sample.
    pub sample: Option<String>,
    /// Every plan point (theta_i, theta_r) in degrees, in plan order.
    pub points: Vec<(f32, f32)>,
}
