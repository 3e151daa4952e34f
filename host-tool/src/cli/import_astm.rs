//! `gonio import astm`: the plane of incidence of an ASTM E1392-style table as a sweep file.

use std::path::PathBuf;

use clap::Args;

use super::error::{CliError, CliResult};
use crate::import::astm::read_astm;
use crate::import::{repeats_said, write_distinct};
use crate::outfile::Target;
use crate::sweep_file::{BrdfUnits, read_input};

/// `gonio import astm`.
#[derive(Debug, Args)]
#[command(
    about = "Read the plane of incidence of an ASTM E1392-style BRDF table into a sweep file",
    long_about = "Read an ASTM E1392-style BRDF table (header lines, NUM_POINTS n, VARS \
theta_i,phi_i,theta_s,phi_s,CHANNEL..., then comma-separated rows with the angles in radians \
and the BRDF in 1/sr) and write the rows in the plane of incidence as a sweep file \
theta_i,theta_r,brdf in degrees and 1/sr.\n\n\
In the plane: phi_s = phi_i + pi (the specular side, theta_r = +theta_s), phi_s = phi_i (the \
source's side, theta_r = -theta_s), compared modulo 2 pi within 0.001 rad, and any phi_s where \
theta_s = 0. Other rows are counted in a # line and on stderr, not read. See docs/formats.md.",
    after_help = "Examples:\n  gonio import astm paint.astm --out paint.csv\n  gonio import astm tile.astm --out tile-g.csv --channel G"
)]
pub struct AstmArgs {
    /// The ASTM table.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The sweep file to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: PathBuf,
    /// Which channel (a name on the VARS line, e.g. R, G, B or 550nm) [default: the only one].
    #[arg(long, value_name = "NAME")]
    pub channel: Option<String>,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
}

/// The table's measurement header lines ([`crate::export::astm::HEADER_KEYS`]) as sweep
/// metadata lines, checked as a sweep's are; none (said on stderr) when one is bad.
fn measurement_lines(name: &str, header: &[(String, String)]) -> Vec<String> {
    let meta: std::collections::BTreeMap<String, String> = header
        .iter()
        .filter_map(|(k, v)| Some((crate::export::astm::sweep_key(k)?.to_string(), v.clone())))
        .collect();
    match crate::sweep_file::Measurement::from_meta(&meta) {
        Ok(m) if m.problem().is_none() => m
            .lines()
            .into_iter()
            .map(|(k, v)| format!("{k}: {v}"))
            .collect(),
        Ok(m) => {
            eprintln!(
                "gonio: warning: {name}: {}: the measurement lines were left out",
                m.problem().unwrap_or_default()
            );
            Vec::new()
        }
        Err(e) => {
            eprintln!(
                "gonio: warning: {name}: the header's {}: the measurement lines were left out",
                crate::text::escape_line(&e, 200)
            );
            Vec::new()
        }
    }
}

/// Runs `gonio import astm`.
pub fn run(args: &AstmArgs) -> CliResult {
    let inputs = [args.file.as_path()];
    let target = Target::new(&args.out, args.force).inputs(&inputs);
    crate::outfile::check(target)?;
    let bytes = read_input(&args.file, "ASTM tables of text")?;
    let name = args.file.display();
    let text = std::str::from_utf8(&bytes)
        .map_err(|_| CliError::usage(format!("{name}: not UTF-8 text: not an ASTM E1392 table")))?;
    let sweep = read_astm(text, args.channel.as_deref())
        .map_err(|(line, m)| CliError::usage(format!("{name}:{line}: {m}")))?;
    let source = args.file.file_name().map_or_else(
        || args.file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let meta = vec![
        format!(
            "source: ASTM E1392 table {source}, channel {} of {}, the plane of incidence (phi_s = phi_i + pi: theta_r = +theta_s; phi_s = phi_i: -theta_s), imported with gonio import astm",
            sweep.channel,
            sweep.channels.join(",")
        ),
        "units: degrees".to_string(),
        format!("brdf: {}", BrdfUnits::PerSr),
        format!(
            "out-of-plane: {} rows out of the plane of incidence were left out",
            sweep.out_of_plane
        ),
    ];
    let mut meta = meta;
    meta.extend(measurement_lines(&name.to_string(), &sweep.header));
    let merged = write_distinct(target, &meta, &sweep.rows)?;
    super::output::say_written(std::slice::from_ref(&args.out));
    if let Some(line) = repeats_said(&name.to_string(), merged) {
        eprintln!("{line}");
    }
    if sweep.out_of_plane > 0 {
        eprintln!(
            "gonio: {} of {} rows of {name} lie out of the plane of incidence and were left out",
            sweep.out_of_plane,
            sweep.out_of_plane + sweep.rows.len()
        );
    }
    Ok(())
}
