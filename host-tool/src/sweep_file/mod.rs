//! The sweep file: CSV with `#` metadata lines, written row by row as readings arrive
//! (each row flushed and synced, so a crash loses nothing that arrived), and read back
//! tolerating a file cut at any byte.
//!
//! ```text
//! # gonio sweep v1
//! # status: complete     readings=0000153 missing=0000000 gaps=0000000 dropped=0000000 timeouts=0000000 rejected=0000000
//! # device: qemu firmware 0.1.0 protocol 1
//! # sample: simulated fe-0.115 noise=0.005      (only where the capture knows it)
//! # units: degrees
//! # brdf: relative
//! # plan: paper
//! # settings: samples=4 settle_ms=50 dark=false exclude_retro=0
//! # started: 2026-11-22T00:15:02Z
//! # points: 0:-80 0:-70 ...
//! theta_i,theta_r,brdf,std,n,seq,t_ms
//! 0,-80,95.16103,0.41,4,0,12
//! ```
//!
//! Angles in degrees (theta_r signed, positive on the specular side), brdf (and std) in
//! the units of the `# brdf:` line: `relative` (the instrument's units, what a capture
//! writes; also assumed when the line is absent) or `1/sr` (after `gonio convert`).
//! Readers find columns by name, in any case; only `theta_i,theta_r,brdf` are required;
//! the table's delimiter is `,` `;` or tab, sniffed from the header row. The `status` line has a fixed width and is
//! rewritten in place when the capture ends; `points` lists the whole plan (after the
//! exclusion zone) so `--resume` knows what is missing; `seq` indexes it.
//! The only `#` lines among the rows are a capture's `# warning:` lines (a device that
//! restarted mid-sweep, written before the first reading after it), read into
//! [`SweepData::notes`] and said by [`SweepData::warnings`].

mod format;
mod header_row;
mod measurement;
mod radians;
mod read;
mod units;
mod whole;
mod write;

pub use header_row::{DELIMITERS, delimiter_name, sniff_delimiter};
pub use measurement::{Measurement, Role};
pub use radians::{ANGLE_UNITS, angles_look_like_radians, looks_like_radians, radians_warning};
pub use read::{MAX_SWEEP_BYTES, SATURATED_PREFIX, SweepData, parse_sweep, read_input, read_sweep};
pub use units::{BRDF_KEY, BrdfUnits, refuse_mixed};
pub use whole::{text_problem, write_text};
pub use write::SweepWriter;

pub use format::{
    ANGLE_MAX_DEG, BRDF_MAX, BRDF_MIN, COLUMNS, Counters, Header, KNOWN_KEYS, MEASUREMENT_KEYS,
    Row, SweepFileError, SweepStatus, brdf_in_range, meta_problem, row_problem,
};

#[cfg(test)]
mod tests;
