//! `gonio import table`: another instrument's in-plane table as a sweep file.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use super::error::{CliError, CliResult};
use crate::import::table::{
    ColumnRef, Columns, Delimiter, QUANTITIES, TableSpec, ThetaRSign, delimiter_name,
    parse_columns, read_table,
};
use crate::import::write_file;
use crate::outfile::Target;
use crate::sweep_file::{BrdfUnits, Row, looks_like_radians, read_input};

/// Angle units on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AnglesArg {
    /// Degrees.
    Deg,
    /// Radians (converted to degrees).
    Rad,
}

/// The theta_r sign convention on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SignArg {
    /// Positive theta_r lies on the specular side, opposite the source (gonio's).
    Specular,
    /// Positive theta_r lies on the source's side (gonio negates it).
    Source,
}

/// `gonio import table`.
#[derive(Debug, Args)]
#[command(
    about = "Read another instrument's in-plane table into a sweep file",
    long_about = "Read another instrument's in-plane table (one row per reading: incidence, \
detector angle, BRDF) into a sweep file theta_i,theta_r,brdf, in degrees with theta_r signed \
positive on the specular side, and a '# brdf:' line saying the units given with --brdf.\n\n\
Lines starting with # and blank lines are skipped; the first other line is the header row \
(unless --no-header). The delimiter is ',' ';' tab or whitespace, sniffed from that line \
unless --delimiter says. A header without a named column, a short row, a value that is not a \
finite number, an angle out of range (theta_i in [0, 90], theta_r in [-90, 90] degrees), a \
negative std or no rows is refused with its line, and nothing is written. With std=NAME in \
--columns the sweep gets std and n columns (n = 1: the table's std is the reading's own), which \
the fit's goodness-of-fit against the noise uses. See docs/formats.md.",
    after_help = "Examples:\n  gonio import table scan.csv --out scan-sweep.csv --columns theta_i=AOI,theta_r=AOS,brdf=BRDF --brdf 1/sr\n  \
gonio import table scan.csv --out scan-sweep.csv --columns theta_i=AOI,theta_r=AOS,brdf=BRDF,std=SIGMA --brdf 1/sr\n  \
gonio import table export.txt --out s.csv --columns theta_i=Theta_i,theta_r=Theta_s,brdf=BRDF --delimiter ';' --decimal-comma --angles rad --theta-r-sign source --brdf relative\n  \
gonio import table solar_array_brdf.csv --out solar.csv --no-header --columns theta_i=1,theta_r=3,brdf=5 --brdf 1/sr"
)]
pub struct TableArgs {
    /// The table to read.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The sweep file to write.
    #[arg(long, value_name = "SWEEP.csv")]
    pub out: PathBuf,
    /// Which columns hold theta_i, theta_r and brdf, and optionally std (each reading's
    /// standard deviation, brdf units): header names (any case) or 1-based column numbers.
    #[arg(long, value_name = "theta_i=NAME,theta_r=NAME,brdf=NAME[,std=NAME]", value_parser = parse_columns)]
    pub columns: Columns,
    /// The units of the brdf column: `1/sr` or `relative` (the instrument's own units).
    #[arg(long = "brdf", value_name = "1/sr|relative", value_parser = BrdfUnits::parse)]
    pub units: BrdfUnits,
    /// The delimiter: `,` `;` `tab` or `space` (runs of spaces or tabs) [default: sniffed].
    #[arg(long, value_name = "DELIM", value_parser = parse_delimiter)]
    pub delimiter: Option<Delimiter>,
    /// Numbers are written with a decimal comma (`0,5`); needs a delimiter other than `,`.
    #[arg(long = "decimal-comma")]
    pub decimal_comma: bool,
    /// The units of both angle columns.
    #[arg(long, value_enum, default_value_t = AnglesArg::Deg)]
    pub angles: AnglesArg,
    /// Which side a positive theta_r lies on in the table.
    #[arg(long = "theta-r-sign", value_enum, default_value_t = SignArg::Specular)]
    pub sign: SignArg,
    /// The table has no header row: --columns gives column numbers.
    #[arg(long = "no-header")]
    pub no_header: bool,
    /// Lines of free text to skip before the table.
    #[arg(long = "skip-lines", value_name = "N", default_value_t = 0)]
    pub skip_lines: usize,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Parses `--delimiter`.
fn parse_delimiter(s: &str) -> Result<Delimiter, String> {
    match s.to_ascii_lowercase().as_str() {
        "," | "comma" => Ok(Delimiter::Char(b',')),
        ";" | "semicolon" => Ok(Delimiter::Char(b';')),
        "tab" | "\t" | "\\t" => Ok(Delimiter::Char(b'\t')),
        "space" | "whitespace" | " " => Ok(Delimiter::Whitespace),
        _ => Err(format!("'{s}': the delimiter is one of , ; tab space")),
    }
}

/// Runs `gonio import table`.
pub fn run(args: &TableArgs) -> CliResult {
    let inputs = [args.file.as_path()];
    let target = Target::new(&args.out, args.force).inputs(&inputs);
    crate::outfile::check(target).map_err(CliError::from)?;
    let bytes =
        read_input(&args.file, "tables of text").map_err(|e| CliError::usage(e.to_string()))?;
    let name = args.file.display();
    let text = std::str::from_utf8(&bytes).map_err(|_| {
        CliError::usage(format!(
            "{name}: not UTF-8 text: gonio import table reads text tables"
        ))
    })?;
    let spec = TableSpec {
        columns: args.columns.required.clone(),
        std: args.columns.std.clone(),
        delimiter: args.delimiter,
        decimal_comma: args.decimal_comma,
        radians: args.angles == AnglesArg::Rad,
        sign: match args.sign {
            SignArg::Specular => ThetaRSign::Specular,
            SignArg::Source => ThetaRSign::Source,
        },
        no_header: args.no_header,
        skip_lines: args.skip_lines,
        units: args.units,
    };
    let table = read_table(text, &spec)
        .map_err(|(line, m)| CliError::usage(format!("{name}:{line}: {m}")))?;
    let rows: Vec<Row> = table
        .rows
        .iter()
        .map(|&(theta_i, theta_r, brdf)| Row::new(theta_i, theta_r, brdf))
        .collect();
    if !spec.radians
        && let Some(max) = looks_like_radians(&rows)
    {
        eprintln!(
            "gonio: warning: every angle of {name} lies within {max:.4} degrees: if they are radians, import again with --angles rad"
        );
    }
    let source = args.file.file_name().map_or_else(
        || args.file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let cols: Vec<String> = QUANTITIES
        .iter()
        .zip(spec.columns.iter().chain(&spec.std))
        .map(|(q, c)| match c {
            ColumnRef::Name(n) => format!("{q}={n}"),
            ColumnRef::Position(p) => format!("{q}=column {p}"),
        })
        .collect();
    let meta = vec![
        format!(
            "source: table {source}, {}, delimiter {}{}, angles in {}, theta_r positive on the {} side{}",
            cols.join(" "),
            delimiter_name(table.delimiter),
            if spec.decimal_comma {
                ", decimal comma"
            } else {
                ""
            },
            if spec.radians {
                "radians (converted)"
            } else {
                "degrees"
            },
            match spec.sign {
                ThetaRSign::Specular => "specular",
                ThetaRSign::Source => "source's (negated)",
            },
            ", imported with gonio import table"
        ),
        "units: degrees".to_string(),
        format!("brdf: {}", spec.units),
    ];
    write_file(target, &meta, &table.rows, &table.std).map_err(CliError::from)?;
    super::output::say_written(std::slice::from_ref(&args.out));
    Ok(())
}
