//! `gonio import`: measurements made elsewhere into gonio's sweep-file format
//! (`gonio import merl`, `astm`, `rgl`, `table`).

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

use super::args::{Angles, parse_angles, theta_r_angles};
use super::error::{CliError, CliResult};
use crate::import::merl::{self, Channel, MerlFile};

/// `gonio import`.
#[derive(Debug, Args)]
#[command(about = "Import measurements made elsewhere as a sweep file")]
pub struct ImportArgs {
    /// The format to import.
    #[command(subcommand)]
    pub format: ImportFormat,
}

/// What `gonio import` reads.
#[derive(Debug, Subcommand)]
pub enum ImportFormat {
    /// A MERL BRDF database file (.binary).
    Merl(MerlArgs),
    /// An ASTM E1392-style BRDF table (its plane of incidence).
    Astm(super::import_astm::AstmArgs),
    /// An RGL-EPFL measured material (RGB tensor file), in the plane of incidence.
    Rgl(super::import_rgl::RglArgs),
    /// Another instrument's in-plane table (columns named with --columns).
    Table(super::import_table::TableArgs),
}

/// Colour channel on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ChannelArg {
    /// Red (scale 1/1500).
    Red,
    /// Green (scale 1.15/1500).
    Green,
    /// Blue (scale 1.66/1500).
    Blue,
    /// The average of the three scaled channels.
    Mean,
}

/// `gonio import merl`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Sample a MERL BRDF database file in the plane of incidence into a sweep file",
    long_about = "Sample a MERL BRDF database file (90 x 90 x 180 half/difference-angle table, \
three channels) in the plane of incidence and write a sweep file theta_i,theta_r,brdf with \
the brdf column in 1/sr (its header says so and names the source and channel).\n\n\
As the reference reader BRDFRead.cpp: cell indices by truncation, no interpolation. In the \
plane phi_d is 0 or 180 degrees, on the border of phi cells 0 and 179 (both hold the in-plane \
value): cell 0 is used, and at the mirror point too (phi_d means nothing there). A requested \
point on a missing (negative) cell is left out and a # line says how many were. A file of the \
wrong size or a Git LFS pointer is refused and nothing is written.\n\n\
Angles in degrees: theta_i in [0, 90]; theta_r signed in [-90, 90], positive on the specular side.",
    after_help = "Examples:\n  gonio import merl gold-metallic-paint.binary --out gold.csv\n  \
gonio import merl alum-bronze.binary --out ab.csv --channel red --theta-i 0:60:20 --theta-r=-85:85:0.5"
)]
pub struct MerlArgs {
    /// The MERL BRDF file.
    #[arg(value_name = "FILE.binary")]
    pub file: PathBuf,
    /// The sweep file to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: PathBuf,
    /// Which channel's BRDF to take.
    #[arg(long, value_enum, default_value_t = ChannelArg::Mean)]
    pub channel: ChannelArg,
    /// Incidence angles in degrees: `a,b,c` or `start:stop:step` [default: 0:80:10, the
    /// paper's].
    #[arg(long = "theta-i", value_name = "LIST", default_value = "0:80:10")]
    pub theta_i: String,
    /// Detector angles in degrees, signed: `a,b,c` or `start:stop:step`, or a mix
    /// [default: -80:80:1].
    #[arg(
        long = "theta-r",
        value_name = "SPEC",
        allow_hyphen_values = true,
        default_value = "-80:80:1",
        value_parser = theta_r_angles
    )]
    pub theta_r: Angles,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Runs `gonio import`.
pub fn run(args: &ImportArgs) -> CliResult {
    match &args.format {
        ImportFormat::Merl(a) => run_merl(a),
        ImportFormat::Astm(a) => super::import_astm::run(a),
        ImportFormat::Rgl(a) => super::import_rgl::run(a),
        ImportFormat::Table(a) => super::import_table::run(a),
    }
}

fn run_merl(args: &MerlArgs) -> CliResult {
    let theta_i = parse_angles("--theta-i", &args.theta_i)?;
    crate::import::check_grid(theta_i.len(), args.theta_r.0.len()).map_err(CliError::usage)?;
    let channel = match args.channel {
        ChannelArg::Red => Channel::Red,
        ChannelArg::Green => Channel::Green,
        ChannelArg::Blue => Channel::Blue,
        ChannelArg::Mean => Channel::Mean,
    };
    if !args.force && args.out.exists() {
        return Err(CliError::usage(format!(
            "{} exists: use --force to overwrite it",
            args.out.display()
        )));
    }
    let table = MerlFile::read(&args.file).map_err(CliError::from)?;
    let sweep = table
        .in_plane(channel, &theta_i, &args.theta_r.0)
        .map_err(CliError::from)?;
    if sweep.rows.is_empty() {
        return Err(CliError::usage(format!(
            "{}: every requested point falls on a missing cell; nothing written",
            args.file.display()
        )));
    }
    let source = args.file.file_name().map_or_else(
        || args.file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let merged = merl::write_file(&args.out, &sweep, &source, channel, args.force)
        .map_err(CliError::from)?;
    super::output::say_written(std::slice::from_ref(&args.out));
    if let Some(line) = crate::import::repeats_said(&args.file.display().to_string(), merged) {
        eprintln!("{line}");
    }
    if sweep.missing > 0 {
        eprintln!(
            "gonio: {} of {} requested points fall on missing MERL cells and were left out",
            sweep.missing,
            sweep.missing + sweep.rows.len()
        );
    }
    Ok(())
}
