//! `gonio eval`: evaluates the model at one incidence and a list of detector angles.

use brdf_core::model::{KDD_PAPER, KID_PAPER, SIGMA_M_PAPER};
use brdf_core::{Model, Params, Preset, Real};
use clap::{Args, ValueEnum};

use super::args::{Angles, EvalModel, theta_r_angles};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::fit::Kind;

/// Float precision of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Precision {
    /// Double precision (the host's default).
    F64,
    /// Single precision, as on the microcontroller.
    F32,
}

/// Arguments of `gonio eval`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Evaluate the BRDF at one incidence angle and a list of detector angles",
    long_about = "Evaluate the BRDF at one incidence angle and a list of detector angles, \
in the plane of incidence.\n\n\
Angles are in degrees. theta_i is in [0, 90]; theta_r is signed in [-90, 90]: positive \
on the specular side, so theta_r = +theta_i is the mirror direction and theta_r = -theta_i \
is retro-reflection. BRDF values are in the paper's relative units.\n\n\
Output: CSV on stdout with the header theta_i,theta_r,brdf and one row per theta_r; \
values are printed in their shortest exact (round-trip) form.",
    after_help = "Examples:\n  gonio eval --material fe-0.115 --theta-i 20 --theta-r -80:80:10\n  \
gonio eval --ks 145 --sigma 0.115 --theta-i 20 --theta-r=-20,0,20 --precision f32\n  \
gonio eval --model ts --material cu-0.070 --kd 30 --theta-i 40 --theta-r 0:90:5"
)]
pub struct EvalArgs {
    /// Model: `three` (specular + directional diffuse + ideal diffuse) or `ts`
    /// (Torrance–Sparrow: specular + constant k_d).
    #[arg(long, value_enum, default_value_t = EvalModel(Kind::ThreeComponent))]
    pub model: EvalModel,
    /// Material preset from the paper: al-0.087, al-0.142, al-0.782, cu-0.070, fe-0.115.
    /// Gives sigma and k_s(theta_i) (linear between the tabulated 0, 10, ..., 80 degrees).
    #[arg(
        long,
        value_name = "PRESET",
        conflicts_with = "ks",
        required_unless_present = "ks"
    )]
    pub material: Option<String>,
    /// Specular weight k_s (>= 0). Use with --sigma instead of --material.
    #[arg(long, value_name = "K", requires = "sigma")]
    pub ks: Option<f64>,
    /// Microfacet slope parameter sigma (> 0, dimensionless). Overrides the preset's.
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Directional-diffuse weight k_dd (>= 0) [three-component model; default 900].
    #[arg(long, value_name = "K")]
    pub kdd: Option<f64>,
    /// Ideal-diffuse weight k_id (>= 0) [three-component model; default 25].
    #[arg(long, value_name = "K")]
    pub kid: Option<f64>,
    /// Directional-diffuse width sigma_m in radians (> 0) [three-component; default 0.7].
    #[arg(long = "sigma-m", value_name = "S")]
    pub sigma_m: Option<f64>,
    /// Constant diffuse term k_d (>= 0) [Torrance–Sparrow model; default 25].
    #[arg(long, value_name = "KD")]
    pub kd: Option<f64>,
    /// Incidence angle theta_i in degrees, in [0, 90].
    #[arg(long = "theta-i", value_name = "DEG", allow_hyphen_values = true)]
    pub theta_i: f64,
    /// Detector angles in degrees, signed, in [-90, 90]: `a,b,c` or `start:stop:step`
    /// (stop included), or a mix. Negative values work as `--theta-r=-80:80:10` and as
    /// `--theta-r -80:80:10`.
    #[arg(
        long = "theta-r",
        value_name = "SPEC",
        allow_hyphen_values = true,
        value_parser = theta_r_angles
    )]
    pub theta_r: Angles,
    /// Float precision of the evaluation (f32 is what the firmware uses).
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
}

/// Runs `gonio eval`: validates everything first, so bad input prints nothing on stdout.
pub fn run(args: &EvalArgs) -> CliResult {
    let theta_r = &args.theta_r.0;
    let mut csv = String::from("theta_i,theta_r,brdf\n");
    match args.precision {
        Precision::F64 => rows::<f64>(args, theta_r, &mut csv)?,
        Precision::F32 => rows::<f32>(args, theta_r, &mut csv)?,
    }
    write_stdout(csv.as_bytes())
}

fn rows<T: Real>(args: &EvalArgs, theta_r: &[f64], csv: &mut String) -> CliResult {
    use std::fmt::Write as _;
    let model = build_model::<T>(args)?;
    let ti = T::lit(args.theta_i);
    for &tr in theta_r {
        let e = model.eval_in_plane(ti, T::lit(tr))?;
        writeln!(csv, "{},{},{}", args.theta_i, tr, e.f).expect("writing to a String");
    }
    Ok(())
}

fn build_model<T: Real>(args: &EvalArgs) -> CliResult<Model<T>> {
    let ti = T::lit(args.theta_i);
    // theta_i is checked here too so that its error wins over a preset lookup's.
    brdf_core::geometry::check_angle("theta_i", ti, 0.0, 90.0)?;
    let (ks, sigma) = match (&args.material, args.ks) {
        (Some(name), _) => {
            let preset = Preset::by_name(name)
                .map_err(|e| CliError::usage(format!("--material '{name}': {e}")))?;
            (preset.ks(ti)?, T::lit(args.sigma.unwrap_or(preset.sigma)))
        }
        (None, Some(ks)) => (
            T::lit(ks),
            T::lit(args.sigma.expect("clap requires --sigma")),
        ),
        (None, None) => unreachable!("clap requires --material or --ks"),
    };
    let lit = |v: Option<f64>, default: f64| T::lit(v.unwrap_or(default));
    let model = match args.model.0 {
        Kind::ThreeComponent => {
            if args.kd.is_some() {
                return Err(CliError::usage(
                    "--kd belongs to --model ts; the three-component model uses --kdd, --kid, --sigma-m",
                ));
            }
            Model::three_component(Params {
                ks,
                sigma,
                kdd: lit(args.kdd, KDD_PAPER),
                sigma_m: lit(args.sigma_m, SIGMA_M_PAPER),
                kid: lit(args.kid, KID_PAPER),
            })?
        }
        Kind::TorranceSparrow => {
            if args.kdd.is_some() || args.kid.is_some() || args.sigma_m.is_some() {
                return Err(CliError::usage(
                    "--kdd, --kid and --sigma-m belong to --model three; --model ts uses --kd",
                ));
            }
            Model::torrance_sparrow(ks, sigma, lit(args.kd, KID_PAPER))?
        }
        other => unreachable!("eval offers no {}", other.name()),
    };
    Ok(model)
}
