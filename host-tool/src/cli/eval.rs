//! `gonio eval`: evaluates any member of the model family at one incidence and a list
//! of detector angles.

use brdf_core::error::Short;
use brdf_core::lobe::SmoothKs;
use brdf_core::member::{KsForm, LobeSpec, Member};
use brdf_core::member_model::{DirectionalParams, Ks, LobeParams, MemberModel, MemberParams};
use brdf_core::model::{KDD_PAPER, KID_PAPER, SIGMA_M_PAPER};
use brdf_core::{Preset, Real};
use clap::{Args, ValueEnum};

use super::args::{Angles, theta_r_angles};
use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::fit::Kind;
use crate::fit::paper::lobe_tail;
use crate::sweep_file::{angles_look_like_radians, radians_warning};

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
Any member of the family: a paper name (ideal-diffuse, torrance-sparrow, three-component, \
three-component-smooth-ks; or their short names ideal, ts, three, three-smooth) or a systematic \
name joining components with '+': specular, specular-haze, directional-diffuse, ideal-diffuse; a \
lobe takes :beckmann (default), :ggx or :student-t (its tail exponent from --gamma or --gamma-haze) and \
:smooth-ks (ln k_s = c0 + c1 t + c2 t^2, t = theta_i/90), e.g. specular:ggx+specular-haze+ideal-diffuse or \
specular:student-t+specular-haze:ggx+ideal-diffuse: whatever `gonio fit` selects but a :fresnel lobe. The haze \
lobe's distribution comes from its name.\n\n\
Output: CSV on stdout with the header theta_i,theta_r,brdf and one row per theta_r; \
values are printed in their shortest exact (round-trip) form.",
    after_help = "Examples:\n  gonio eval --material fe-0.115 --theta-i 20 --theta-r -80:80:10\n  \
gonio eval --ks 145 --sigma 0.115 --theta-i 20 --theta-r=-20,0,20 --precision f32\n  \
gonio eval --model ts --material cu-0.070 --kd 30 --theta-i 40 --theta-r 0:90:5\n  \
gonio eval --model specular+specular-haze:ggx+ideal-diffuse --ks 5000 --sigma 0.005 \
--ks-haze 20 --sigma-haze 0.2 --kid 1 --theta-i 30 --theta-r 0:60:1\n  \
gonio eval --model three-component-smooth-ks --ks-smooth 5,0.5,-0.2 --sigma 0.1 --theta-i 40 --theta-r 0:80:10\n  \
gonio eval --model specular:student-t+specular-haze:ggx+ideal-diffuse --ks 0.2 --sigma 0.0055 --gamma 2.1 \
--ks-haze 0.04 --sigma-haze 0.055 --kid 0.03 --theta-i 30 --theta-r 25:35:0.5"
)]
pub struct EvalArgs {
    /// The member: `three` (specular + directional diffuse + ideal diffuse, the
    /// default), `ts` (Torrance–Sparrow: specular + constant k_d), any paper name or any
    /// systematic name (see above).
    #[arg(long, value_name = "MEMBER", default_value = "three")]
    pub model: String,
    /// Material preset from the paper: al-0.087, al-0.142, al-0.782, cu-0.070, fe-0.115.
    /// Gives sigma and k_s(theta_i) (linear between the tabulated 0, 10, ..., 80 degrees)
    /// of the core lobe (per-incidence k_s).
    #[arg(long, value_name = "PRESET", conflicts_with_all = ["ks", "ks_smooth"])]
    pub material: Option<String>,
    /// Specular weight k_s (>= 0). Use with --sigma instead of --material.
    #[arg(long, value_name = "K", requires = "sigma")]
    pub ks: Option<f64>,
    /// Microfacet slope parameter sigma (> 0, dimensionless). Overrides the preset's.
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Smooth k_s of the core lobe: C0,C1,C2 of ln k_s = c0 + c1 t + c2 t^2, t =
    /// theta_i / 90 [members whose specular is :smooth-ks; with --sigma].
    #[arg(long = "ks-smooth", value_name = "C0,C1,C2", value_parser = coefficients, requires = "sigma")]
    pub ks_smooth: Option<[f64; 3]>,
    /// Tail exponent gamma (> 1) of a :student-t specular lobe [required for one]: GGX's
    /// tail at 2, Beckmann's as gamma grows; `gonio fit` reports it as `gamma`.
    #[arg(long, value_name = "G")]
    pub gamma: Option<f64>,
    /// The haze lobe's k_s (>= 0) [members with specular-haze].
    #[arg(long = "ks-haze", value_name = "K", conflicts_with = "ks_haze_smooth")]
    pub ks_haze: Option<f64>,
    /// The haze lobe's smooth k_s: C0,C1,C2 as --ks-smooth [specular-haze:smooth-ks].
    #[arg(long = "ks-haze-smooth", value_name = "C0,C1,C2", value_parser = coefficients)]
    pub ks_haze_smooth: Option<[f64; 3]>,
    /// The haze lobe's width sigma (> 0, dimensionless) [members with specular-haze].
    #[arg(long = "sigma-haze", value_name = "S")]
    pub sigma_haze: Option<f64>,
    /// Tail exponent gamma (> 1) of a :student-t haze lobe [required for one]; `gonio
    /// fit` reports it as `gamma_haze`.
    #[arg(long = "gamma-haze", value_name = "G")]
    pub gamma_haze: Option<f64>,
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

/// `C0,C1,C2`: three finite numbers (a clap value parser).
fn coefficients(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}': expected three numbers C0,C1,C2"))?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        _ => Err(format!("'{s}': expected three finite numbers C0,C1,C2")),
    }
}

/// The member `--model` names: the command-line short names of the paper's members
/// (`three`, `ts`, ...), their paper names, or any systematic name.
pub fn parse_member(name: &str) -> CliResult<Member> {
    let shown = crate::text::escape_line(name, 80);
    if let Some(kind) = Kind::from_cli_name(name.trim()) {
        return Member::parse(kind.name())
            .map_err(|e| CliError::usage(format!("--model '{shown}': {e}")));
    }
    Member::parse(name).map_err(|e| CliError::usage(format!("--model '{shown}': {e}")))
}

/// Runs `gonio eval`: validates everything first, so bad input prints nothing on stdout.
pub fn run(args: &EvalArgs) -> CliResult {
    let theta_r = &args.theta_r.0;
    let mut csv = String::from("theta_i,theta_r,brdf\n");
    match args.precision {
        Precision::F64 => rows::<f64>(args, theta_r, &mut csv)?,
        Precision::F32 => {
            fits_f32(args)?;
            rows::<f32>(args, theta_r, &mut csv)?
        }
    }
    // As `gonio fit` warns of a sweep's: after the checks, so bad input stays one line.
    let angles = std::iter::once(args.theta_i).chain(theta_r.iter().copied());
    if let Some(max) = angles_look_like_radians(theta_r.len(), angles) {
        eprintln!(
            "gonio: warning: {}",
            radians_warning("--theta-i and --theta-r", max)
        );
    }
    write_stdout(csv.as_bytes())
}

/// With `--precision f32`: every number given must be an f32 (finite, not rounded to
/// 0 or to a denormal); else the option is named with the limit it crosses.
fn fits_f32(args: &EvalArgs) -> CliResult {
    let one = |name: &str, v: f64| -> CliResult {
        let a = v.abs();
        // Not finite: the model's own check says so, naming the quantity.
        if !a.is_finite() || a == 0.0 {
            return Ok(());
        }
        let limit = if a > f64::from(f32::MAX) {
            format!("overflows f32 (largest {:e})", f32::MAX)
        } else if a < f64::from(f32::MIN_POSITIVE) {
            format!("underflows f32 (smallest normal {:e})", f32::MIN_POSITIVE)
        } else {
            return Ok(());
        };
        Err(CliError::usage(format!(
            "{name} {} {limit}: use --precision f64",
            Short(v)
        )))
    };
    let scalars = [
        ("--ks", args.ks),
        ("--sigma", args.sigma),
        ("--ks-haze", args.ks_haze),
        ("--sigma-haze", args.sigma_haze),
        ("--gamma", args.gamma),
        ("--gamma-haze", args.gamma_haze),
        ("--kdd", args.kdd),
        ("--kid", args.kid),
        ("--sigma-m", args.sigma_m),
        ("--kd", args.kd),
    ];
    for (name, v) in scalars {
        if let Some(v) = v {
            one(name, v)?;
        }
    }
    for (name, c) in [
        ("--ks-smooth", args.ks_smooth),
        ("--ks-haze-smooth", args.ks_haze_smooth),
    ] {
        for v in c.into_iter().flatten() {
            one(name, v)?;
        }
    }
    Ok(())
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

fn build_model<T: Real>(args: &EvalArgs) -> CliResult<MemberModel<T>> {
    let ti = T::lit(args.theta_i);
    // theta_i is checked here too so that its error wins over a preset lookup's.
    brdf_core::geometry::check_angle("theta_i", ti, 0.0, 90.0)?;
    let member = parse_member(&args.model)?;
    let lit = |v: Option<f64>, default: f64| T::lit(v.unwrap_or(default));
    let smooth = |c: [f64; 3]| {
        Ks::Smooth(SmoothKs {
            c: c.map(|x| T::lit(x)),
        })
    };
    let core = match member.core {
        None => {
            if args.material.is_some()
                || args.ks.is_some()
                || args.ks_smooth.is_some()
                || args.sigma.is_some()
                || args.gamma.is_some()
            {
                return Err(CliError::usage(format!(
                    "--model {}: no specular lobe, so --material, --ks, --ks-smooth, --sigma and --gamma do not apply",
                    member
                )));
            }
            None
        }
        Some(spec) => Some(core_lobe(args, &member, spec, ti)?),
    };
    let haze = match member.haze {
        None => {
            if args.ks_haze.is_some()
                || args.ks_haze_smooth.is_some()
                || args.sigma_haze.is_some()
                || args.gamma_haze.is_some()
            {
                return Err(CliError::usage(format!(
                    "--ks-haze, --ks-haze-smooth, --sigma-haze and --gamma-haze belong to members with specular-haze (not {member})"
                )));
            }
            None
        }
        Some(spec) => {
            let sigma = args.sigma_haze.ok_or_else(|| {
                CliError::usage(format!(
                    "--model {member}: the haze lobe needs --sigma-haze S"
                ))
            })?;
            let ks = match (spec.ks, args.ks_haze, args.ks_haze_smooth) {
                (KsForm::PerIncidence, Some(k), None) => Ks::PerIncidence(T::lit(k)),
                (KsForm::Smooth, None, Some(c)) => smooth(c),
                (KsForm::PerIncidence, _, _) => {
                    return Err(CliError::usage(format!(
                        "--model {member}: the haze lobe has k_s per incidence: give --ks-haze K"
                    )));
                }
                (KsForm::Smooth, _, _) => {
                    return Err(CliError::usage(format!(
                        "--model {member}: the haze lobe has a smooth k_s: give --ks-haze-smooth C0,C1,C2"
                    )));
                }
                (KsForm::Fresnel, _, _) => return Err(no_fresnel(&member)),
            };
            Some(LobeParams {
                dist: spec.dist,
                ks,
                sigma: T::lit(sigma),
                gamma: tail::<T>(&member, "haze", spec, ("--gamma-haze", args.gamma_haze))?,
            })
        }
    };
    let directional = if member.directional {
        if args.kd.is_some() {
            return Err(CliError::usage(
                "--kd belongs to --model ts; the three-component model uses --kdd, --kid, --sigma-m",
            ));
        }
        Some(DirectionalParams {
            kdd: lit(args.kdd, KDD_PAPER),
            sigma_m: lit(args.sigma_m, SIGMA_M_PAPER),
        })
    } else {
        // --kid is the constant's other name here (--kd); the directional's are not.
        if args.kdd.is_some() || args.sigma_m.is_some() || (args.kid.is_some() && args.kd.is_some())
        {
            return Err(CliError::usage(
                "--kdd, --kid and --sigma-m belong to --model three; --model ts uses --kd",
            ));
        }
        None
    };
    let ideal = if member.ideal {
        Some(lit(args.kid.or(args.kd), KID_PAPER))
    } else {
        if args.kid.is_some() || args.kd.is_some() {
            return Err(CliError::usage(format!(
                "--model {member} has no ideal-diffuse term: --kid and --kd do not apply"
            )));
        }
        None
    };
    Ok(MemberModel::new(&MemberParams {
        core,
        haze,
        directional,
        ideal,
        abg: None,
    })?)
}

/// The refusal of a `:fresnel` lobe: eval has no options for its k0, n and k.
fn no_fresnel(member: &dyn std::fmt::Display) -> CliError {
    CliError::usage(format!(
        "--model {member}: gonio eval has no options for a :fresnel lobe's k0, n and k (gonio fit fits them; its --json and --export json carry them)"
    ))
}

/// The core lobe from --material or --ks/--ks-smooth with --sigma.
fn core_lobe<T: Real>(
    args: &EvalArgs,
    member: &Member,
    spec: LobeSpec,
    ti: T,
) -> CliResult<LobeParams<T>> {
    if spec.ks == KsForm::Fresnel {
        return Err(no_fresnel(&args.model));
    }
    let (ks, sigma) = match (&args.material, args.ks, args.ks_smooth) {
        (Some(name), _, _) => {
            if spec.ks == KsForm::Smooth {
                return Err(CliError::usage(format!(
                    "--material gives k_s per incidence; a :smooth-ks specular needs --ks-smooth C0,C1,C2 with --sigma (model '{}')",
                    args.model
                )));
            }
            let preset = Preset::by_name(name)
                .map_err(|e| CliError::usage(format!("--material '{name}': {e}")))?;
            (
                Ks::PerIncidence(preset.ks(ti)?),
                T::lit(args.sigma.unwrap_or(preset.sigma)),
            )
        }
        (None, Some(ks), None) if spec.ks == KsForm::PerIncidence => (
            Ks::PerIncidence(T::lit(ks)),
            T::lit(args.sigma.expect("clap requires --sigma")),
        ),
        (None, None, Some(c)) if spec.ks == KsForm::Smooth => (
            Ks::Smooth(SmoothKs {
                c: c.map(|x| T::lit(x)),
            }),
            T::lit(args.sigma.expect("clap requires --sigma")),
        ),
        (None, None, None) => {
            return Err(CliError::usage(
                "the specular lobe needs --material PRESET, or --ks K (or --ks-smooth C0,C1,C2) with --sigma S",
            ));
        }
        _ => {
            return Err(CliError::usage(format!(
                "--model '{}': its specular has {} k_s: use {}",
                args.model,
                spec.ks.name(),
                match spec.ks {
                    KsForm::PerIncidence => "--ks K (or --material)",
                    KsForm::Smooth | KsForm::Fresnel => "--ks-smooth C0,C1,C2",
                }
            )));
        }
    };
    Ok(LobeParams {
        dist: spec.dist,
        ks,
        sigma,
        gamma: tail::<T>(member, "specular", spec, ("--gamma", args.gamma))?,
    })
}

/// A lobe's tail exponent from its option `(flag, value)` ([`lobe_tail`]); `role`
/// names the lobe in the message.
fn tail<T: Real>(
    member: &Member,
    role: &str,
    spec: LobeSpec,
    (flag, given): (&str, Option<f64>),
) -> CliResult<Option<T>> {
    let what = format!("the {role} lobe of {member}");
    lobe_tail(&what, flag, spec.dist, given)
        .map(|g| g.map(T::lit))
        .map_err(CliError::usage)
}
