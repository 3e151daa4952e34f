//! Reading a MERL BRDF database file and sampling it in the plane of incidence.
//!
//! Layout (as the reference reader `BRDFRead.cpp`): three little-endian i32 dims
//! (90, 90, 180), then the red, green and blue blocks of 90 * 90 * 180 little-endian
//! f64 each. Cell `phi_d + 180 theta_d + 16200 theta_h`; stored values times
//! [`MERL_SCALE`] are the BRDF in 1/sr; a negative cell is a direction the database
//! did not measure.
//!
//! In-plane conventions (angles in degrees; theta_r signed, positive on the specular
//! side): the half vector lies theta_h = |theta_r - theta_i| / 2 from the normal and the
//! difference angle is theta_d = |theta_i + theta_r| / 2. Indices by truncation, no
//! interpolation, as the reference: theta_h's index is floor(sqrt(90 theta_h)) (its
//! square-root mapping), theta_d's floor(theta_d), each clamped to the table. In the
//! plane phi_d is 0 or 180 degrees, on the border of phi cells 0 and 179, which both
//! hold the in-plane value: cell 0 is used; at the mirror point (theta_h = 0) phi_d
//! means nothing and cell 0 is used too. The angles are computed in degrees from the
//! requested ones, so a point exactly on a bin edge (theta_h = 10: sqrt(900) = 30) gets
//! the upper bin exactly, where the reference's radian round trip may land either side.

use std::io::{self, Read, Write};
use std::path::Path;

pub use super::error::ImportError;
pub use crate::export::MERL_SCALE;
use crate::export::{MERL_DIMS, MERL_LEN};

/// Bytes of a complete MERL file: the 12-byte header and three channels of f64.
pub const MERL_FILE_LEN: u64 = 12 + 3 * 8 * MERL_LEN as u64;

/// Which BRDF to take from the three colour channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Red (scale 1/1500).
    Red,
    /// Green (scale 1.15/1500).
    Green,
    /// Blue (scale 1.66/1500).
    Blue,
    /// The average of the three scaled channels (missing where any one is).
    Mean,
}

impl Channel {
    /// The name on the command line and in the file's header.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Red => "red",
            Channel::Green => "green",
            Channel::Blue => "blue",
            Channel::Mean => "mean",
        }
    }
}

/// A MERL table, channels as stored (unscaled), in file order.
#[derive(Debug, Clone)]
pub struct MerlFile {
    raw: Vec<f64>,
}

/// The start of a Git LFS pointer file (what a clone without LFS holds instead).
const LFS_MAGIC: &[u8] = b"version https://git-lfs";

impl MerlFile {
    /// Reads and checks a MERL file: a Git LFS pointer, a wrong length or wrong dims
    /// are [`ImportError::Invalid`] with one line naming the file.
    pub fn read(path: &Path) -> Result<MerlFile, ImportError> {
        let name = path.display();
        let bad = |m: String| ImportError::Invalid(format!("{name}: {m}"));
        // Checked before opening: opening a FIFO would wait for a writer for ever.
        let meta = std::fs::metadata(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        if !meta.is_file() {
            return Err(bad(
                "not a regular file (a MERL table is a file of 3 x 90 x 90 x 180 doubles)".into(),
            ));
        }
        let mut file = std::fs::File::open(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let len = file
            .metadata()
            .map_err(|e| bad(format!("cannot read: {e}")))?
            .len();
        // Checked before reading it all: a wrong file may be huge.
        let mut head = Vec::new();
        (&mut file)
            .take(64)
            .read_to_end(&mut head)
            .map_err(|e| bad(format!("cannot read: {e}")))?;
        if head.starts_with(LFS_MAGIC) {
            return Err(bad(
                "a Git LFS pointer, not the MERL table (run `git lfs pull` to fetch it)".into(),
            ));
        }
        if len != MERL_FILE_LEN {
            return Err(bad(format!(
                "{len} bytes, a MERL BRDF file has {MERL_FILE_LEN} (dims 90 x 90 x 180, 3 channels of f64)"
            )));
        }
        let mut bytes = head;
        file.read_to_end(&mut bytes)
            .map_err(|e| bad(format!("cannot read: {e}")))?;
        MerlFile::from_bytes(&bytes).map_err(bad)
    }

    /// Whether `path` holds a MERL BRDF file (its length and its dims header), read
    /// without loading it: for commands that read sweep files to say what to do with
    /// one instead of failing on its bytes.
    pub fn is_merl(path: &Path) -> bool {
        let Ok(meta) = std::fs::metadata(path) else {
            return false;
        };
        let mut head = [0u8; 12];
        meta.is_file()
            && meta.len() == MERL_FILE_LEN
            && std::fs::File::open(path)
                .and_then(|mut f| f.read_exact(&mut head))
                .is_ok()
            && head
                .chunks_exact(4)
                .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .zip(MERL_DIMS)
                .all(|(d, e)| d as i64 == e as i64)
    }

    /// Parses the bytes of a MERL file (checks dims and length).
    pub fn from_bytes(bytes: &[u8]) -> Result<MerlFile, String> {
        if bytes.len() as u64 != MERL_FILE_LEN {
            return Err(format!(
                "{} bytes, a MERL BRDF file has {MERL_FILE_LEN}",
                bytes.len()
            ));
        }
        let dims: Vec<i32> = bytes[..12]
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if dims
            .iter()
            .zip(MERL_DIMS)
            .any(|(&d, e)| d as i64 != e as i64)
        {
            return Err(format!("dims {dims:?}, a MERL BRDF file has {MERL_DIMS:?}"));
        }
        let raw = bytes[12..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        Ok(MerlFile { raw })
    }

    /// The BRDF (1/sr) of `channel` in cell `index`, `None` where the cell is missing
    /// (negative or not finite; for [`Channel::Mean`], where any channel is).
    pub fn value(&self, channel: Channel, index: usize) -> Option<f64> {
        let one = |c: usize| {
            let v = self.raw[c * MERL_LEN + index];
            (v >= 0.0 && v.is_finite()).then(|| v * MERL_SCALE[c])
        };
        match channel {
            Channel::Red => one(0),
            Channel::Green => one(1),
            Channel::Blue => one(2),
            Channel::Mean => Some((one(0)? + one(1)? + one(2)?) / 3.0),
        }
    }

    /// Samples the table on the grid `theta_i` x `theta_r` (degrees, incidence-major).
    /// Angles out of range (theta_i in [0, 90], theta_r in [-90, 90]) are
    /// [`ImportError::Invalid`].
    pub fn in_plane(
        &self,
        channel: Channel,
        theta_i: &[f64],
        theta_r: &[f64],
    ) -> Result<InPlaneSweep, ImportError> {
        let check = |what: &str, v: f64, lo: f64, hi: f64| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(ImportError::Invalid(format!(
                    "{what} = {v} is outside [{lo}, {hi}] degrees"
                )))
            }
        };
        let mut sweep = InPlaneSweep::default();
        for &ti in theta_i {
            check("theta_i", ti, 0.0, 90.0)?;
            for &tr in theta_r {
                check("theta_r", tr, -90.0, 90.0)?;
                match self.value(channel, in_plane_index(ti, tr)) {
                    Some(f) => sweep.rows.push((ti, tr, f)),
                    None => sweep.missing += 1,
                }
            }
        }
        Ok(sweep)
    }
}

/// The MERL cell of an in-plane direction pair (degrees; see the module docs).
pub fn in_plane_index(theta_i: f64, theta_r: f64) -> usize {
    let [nh, nd, np] = MERL_DIMS;
    let theta_h = ((theta_r - theta_i) / 2.0).abs();
    let theta_d = ((theta_i + theta_r) / 2.0).abs();
    let clamp = |x: f64, n: usize| (x.max(0.0) as usize).min(n - 1);
    // 90 degrees of theta_h over 90 cells, square-root mapped: sqrt(theta_h / 90) * 90.
    let ih = clamp((theta_h * nh as f64).sqrt(), nh);
    let id = clamp(theta_d / 90.0 * nd as f64, nd);
    let ip = 0; // phi_d = 0 or 180 in the plane: cell 0 (see the module docs)
    ip + id * np + ih * np * nd
}

/// Readings sampled from a table: `(theta_i, theta_r, brdf)` in degrees and 1/sr, and
/// how many requested points fell on missing cells (left out).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InPlaneSweep {
    /// The readings, in request order.
    pub rows: Vec<(f64, f64, f64)>,
    /// Requested points whose cell is missing.
    pub missing: usize,
}

/// Writes `sweep` in the sweep-file format ([`super::write::write_sweep`]): `#` lines saying
/// where it came from, that the brdf column is in 1/sr and how many points were left
/// out, then `theta_i,theta_r,brdf`.
pub fn write_sweep(
    w: &mut impl Write,
    sweep: &InPlaneSweep,
    source: &str,
    channel: Channel,
) -> io::Result<()> {
    super::write::write_sweep(
        w,
        &merl_meta(source, channel, sweep.missing),
        &sweep.rows,
        &[],
    )
}

/// The `#` lines of a MERL import.
fn merl_meta(source: &str, channel: Channel, missing: usize) -> Vec<String> {
    vec![
        format!(
            "source: MERL BRDF database file {source}, channel {} ({}), cells by truncation, no interpolation",
            channel.name(),
            match channel {
                Channel::Mean => "average of the scaled red, green and blue",
                _ => "scaled as the reference reader",
            }
        ),
        "units: degrees".into(),
        crate::sweep_file::BrdfUnits::PerSr.header_line()[2..]
            .trim_end()
            .to_string(),
        format!(
            "missing: {missing} requested points fall on missing (negative) MERL cells and are left out"
        ),
    ]
}

/// Writes `sweep` to `path` through the export's atomic writer (nothing is left under
/// `path` on failure); an existing `path` is refused unless `force`. Each direction is
/// one row ([`super::write::write_distinct`]): returns how many repeated rows (an angle
/// given twice) were merged.
pub fn write_file(
    path: &Path,
    sweep: &InPlaneSweep,
    source: &str,
    channel: Channel,
    force: bool,
) -> Result<usize, ImportError> {
    super::write::write_distinct(
        crate::outfile::Target::new(path, force),
        &merl_meta(source, channel, sweep.missing),
        &sweep.rows,
    )
}

#[cfg(test)]
#[path = "merl_tests.rs"]
mod tests;
