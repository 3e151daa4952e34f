//! `gonio import rgl`: an RGL-EPFL measured material in the plane of incidence as a sweep file.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::args::{Angles, parse_angles, theta_r_angles};
use super::error::{CliError, CliResult};
use crate::import::rgl::{RglBrdf, RglChannel};
use crate::import::{repeats_said, write_distinct};
use crate::outfile::Target;
use crate::sweep_file::{BRDF_MIN, BrdfUnits, read_input};

/// A file's incidence this close to 90 degrees is its grazing one (pi/2 rounded to f32
/// reads 89.999996): not a default incidence.
const GRAZING_DEG: f64 = 1e-3;

/// A --wavelength this close (nm) to one of the file's is that one.
const SNAP_NM: f64 = 1e-3;

/// The channel on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RglChannelArg {
    /// Red.
    R,
    /// Green.
    G,
    /// Blue.
    B,
    /// Luminance: Rec. 709 (0.2126 R + 0.7152 G + 0.0722 B) of an RGB file, CIE 1931 Y
    /// of a spectral one.
    Y,
}

/// `gonio import rgl`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Evaluate an RGL-EPFL measured material in the plane of incidence into a sweep file",
    long_about = "Evaluate an RGL-EPFL measured material (a tensor_file, Dupuy & Jakob 2018: an \
RGB one, *_rgb.bsdf, or a spectral one, *_spec.bsdf) in the plane of incidence as the reference \
reader rgl-epfl/brdf-loader (powitacq_rgb / powitacq BRDF::eval) does, and write a sweep file \
theta_i,theta_r,brdf with the BRDF f_r in 1/sr (the reference's eval is f_r cos(theta_r); gonio \
divides the cosine out).\n\n\
RGB files: --channel r, g, b or y (Rec. 709 luminance). Spectral files: --wavelength NM (one of \
the file's wavelengths, or linear between the two around it, as the reference's own \
interpolant does along its wavelength axis) or --channel y (CIE 1931 Y under an equal-energy \
illuminant, when the file's wavelengths span 99 % of the ybar integral). Default: y.\n\n\
Angles in degrees: theta_i in [0, 90); theta_r signed in [-90, 90], positive on the specular \
side (0 at grazing exit). See docs/formats.md.",
    after_help = "Examples:\n  gonio import rgl ilm_l3_37_metallic_rgb.bsdf --out l3.csv\n  \
gonio import rgl paint_rgb.bsdf --out paint-r.csv --channel r --theta-i 0,20,40,60 --theta-r=-85:85:0.5\n  \
gonio import rgl felt_spec.bsdf --out felt-550.csv --wavelength 550"
)]
pub struct RglArgs {
    /// The RGL material (RGB tensor file).
    #[arg(value_name = "FILE.bsdf")]
    pub file: PathBuf,
    /// The sweep file to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: PathBuf,
    /// Which channel: r, g, b (RGB files) or y (luminance, both kinds) [default: y].
    #[arg(long, value_enum, conflicts_with = "wavelength")]
    pub channel: Option<RglChannelArg>,
    /// A spectral file's wavelength in nm: one of the file's, or linear between the two
    /// around it.
    #[arg(long, value_name = "NM")]
    pub wavelength: Option<f64>,
    /// Incidences in degrees: `a,b,c` or `start:stop:step` [default: the file's measured
    /// incidences below 90].
    #[arg(long = "theta-i", value_name = "LIST")]
    pub theta_i: Option<String>,
    /// Detector angles in degrees, signed: `a,b,c` or `start:stop:step`.
    #[arg(long = "theta-r", value_name = "SPEC", allow_hyphen_values = true, default_value = "-89:89:1", value_parser = theta_r_angles)]
    pub theta_r: Angles,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Runs `gonio import rgl`.
pub fn run(args: &RglArgs) -> CliResult {
    let inputs = [args.file.as_path()];
    let target = Target::new(&args.out, args.force).inputs(&inputs);
    crate::outfile::check(target)?;
    let name = args.file.display();
    let bytes = read_input(&args.file, "RGL tensor files")?;
    let brdf = crate::import::tensor::read_tensor(&bytes)
        .and_then(|f| RglBrdf::from_fields(&f))
        .map_err(|m| CliError::usage(format!("{name}: {m}")))?;
    let theta_i = match &args.theta_i {
        Some(s) => parse_angles("--theta-i", s)?,
        None => brdf
            .theta_i
            .iter()
            .map(|t| t.to_degrees())
            .filter(|&t| t < 90.0 - GRAZING_DEG)
            .collect(),
    };
    for &t in &theta_i {
        if !(0.0..90.0).contains(&t) {
            return Err(CliError::usage(format!(
                "--theta-i {t}: an incidence lies in [0, 90) degrees"
            )));
        }
    }
    for &t in &args.theta_r.0 {
        if !(-90.0..=90.0).contains(&t) {
            return Err(CliError::usage(format!(
                "--theta-r {t}: a detector angle lies in [-90, 90] degrees"
            )));
        }
    }
    crate::import::check_grid(theta_i.len(), args.theta_r.0.len()).map_err(CliError::usage)?;
    let channel = match (args.wavelength, args.channel) {
        (Some(nm), _) => RglChannel::Nm(snap(nm, brdf.wavelengths().unwrap_or_default())),
        (None, Some(RglChannelArg::R)) => RglChannel::R,
        (None, Some(RglChannelArg::G)) => RglChannel::G,
        (None, Some(RglChannelArg::B)) => RglChannel::B,
        (None, Some(RglChannelArg::Y) | None) => RglChannel::Y,
    };
    brdf.check(channel)
        .map_err(|m| CliError::usage(format!("{name}: {m}")))?;
    let mut rows = Vec::with_capacity(theta_i.len() * args.theta_r.0.len());
    for &ti in &theta_i {
        for &tr in &args.theta_r.0 {
            let f = brdf.in_plane(channel, ti, tr);
            // Below the sweep's smallest magnitude is no reading (f32 round-off): 0.
            rows.push((ti, tr, if f.abs() < BRDF_MIN { 0.0 } else { f }));
        }
    }
    let source = args
        .file
        .file_name()
        .map_or_else(|| name.to_string(), |n| n.to_string_lossy().into_owned());
    let reader = if brdf.wavelengths().is_some() {
        "powitacq"
    } else {
        "powitacq_rgb"
    };
    let mut meta = vec![
        format!(
            "source: RGL-EPFL material {source} ({}), channel {}, evaluated in the plane as {reader} BRDF::eval / cos(theta_r), imported with gonio import rgl",
            crate::text::escape_line(brdf.description.trim(), 120),
            channel.name()
        ),
        "units: degrees".to_string(),
        format!("brdf: {}", BrdfUnits::PerSr),
    ];
    if let Some(w) = brdf.wavelengths() {
        meta.push(wavelength_line(channel, w));
    }
    let merged = write_distinct(target, &meta, &rows)?;
    super::output::say_written(std::slice::from_ref(&args.out));
    if let Some(line) = repeats_said(&name.to_string(), merged) {
        eprintln!("{line}");
    }
    Ok(())
}

/// `nm` as the file's own wavelength when within [`SNAP_NM`] of it (a file holds
/// them in f32: 552.3 reads 552.29999), else as given.
fn snap(nm: f64, file: &[f64]) -> f64 {
    file.iter()
        .copied()
        .find(|w| (w - nm).abs() <= SNAP_NM)
        .unwrap_or(nm)
}

/// The sweep's `wavelength:` line for a spectral file: the wavelength and whether it is
/// one of the file's or interpolated, or the range Y weighs.
fn wavelength_line(channel: RglChannel, w: &[f64]) -> String {
    let (lo, hi) = (w[0], w[w.len() - 1]);
    match channel {
        RglChannel::Nm(nm) => match w.iter().position(|&x| x >= nm) {
            Some(k) if w[k] == nm => format!("wavelength: {nm} nm (one of the file's)"),
            Some(k) => format!(
                "wavelength: {nm} nm (linear between the file's {} and {} nm)",
                w[k - 1],
                w[k]
            ),
            None => unreachable!("checked: within the file's wavelengths"),
        },
        _ => format!(
            "wavelength: CIE 1931 Y over the file's {} wavelengths {lo}..{hi} nm (equal-energy illuminant)",
            w.len()
        ),
    }
}
