//! `gonio fit`'s arguments and the [`Request`] they make.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use brdf_core::member::Member;

use super::args::{parse_export, parse_scale};
use super::error::{CliError, CliResult};
use crate::export::ExportFormat;
use crate::fit::physical::CheckScope;
use crate::fit::{self, FitOptions, Fixed, Loss, Residual};
use crate::request::{Aperture as RequestAperture, InstrumentFile, Request};

/// Residual kind on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ResidualArg {
    /// g(f) - g(y), g(v) = asinh(b v / a) / b: each reading against its noise
    /// sqrt(a^2 + (b y)^2), a floor a and a proportional part b: from the readings' std/n, --noise, or by rule (a
    /// = the level of the lowest tenth of the readings, zeros left out, b = 3 %). The peak and the
    /// haze both count; zero or negative readings (a detector at its floor) are compared
    /// with the floor (default).
    Noise,
    /// ln f - ln y: each decade of the curve counts alike (the haze's many readings
    /// outvote the peak's few).
    Log,
    /// (f - y) / y.
    Rel,
    /// f - y in the instrument's units (allows zero or negative readings).
    Abs,
}

/// Which models the report's physical checks cover, on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ChecksArg {
    /// Every fitted model (the default for one sweep file).
    All,
    /// The selected model only.
    Selected,
    /// None (the default in a campaign).
    None,
}

/// `gonio fit`.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    about = "Fit the BRDF model family to a sweep file",
    long_about = "Fit a family of BRDF models to a sweep file and say which components the data support.\n\n\
The family is built from four components: specular (the paper's lobe, eq. 3-4), specular-haze (a second, wider \
lobe with its own width), directional-diffuse (eq. 5) and ideal-diffuse (eq. 6); each lobe Beckmann, GGX \
(Trowbridge–Reitz) or Student-t (a slope distribution whose tail exponent gamma is fitted: GGX at 2, Beckmann \
as gamma grows; real metals' sharp cores and heavy wings), its k_s one value per incidence or a smooth \
k_s(theta_i). The paper's members keep their names (ideal-diffuse, torrance-sparrow, three-component, \
three-component-smooth-ks); the others are named by their components, e.g. \
specular:student-t+specular-haze:ggx+ideal-diffuse.\n\n\
The default does not fit every combination. It fits what is needed to decide: first the paper's four members, \
directional-diffuse+ideal-diffuse and three-component with a haze lobe; then, of the component sets with the \
ideal diffuse and the paper's lobe, each one component from the member selected (its claims compare against \
it) or that could still beat it (a member fits no better than a larger member it is nested in, which bounds \
its AICc and BIC), until none is left: so torrance-sparrow with a haze is fitted only when it matters; then, \
for the component set selected, the variants of its core lobe (Beckmann, GGX or Student-t, k_s per incidence or \
smooth), a smooth-k_s variant only when it could be selected (the same member with k_s per incidence bounds it: \
the notes say so when it is left out); then, if the member selected has a haze, that member with each of the \
haze's other distributions; last, the member selected without each of its components, and with each it lacks, \
wherever no fit tests that component yet: every \"supported\" or \"absent\" in the notes compares two fits the \
report names. --models fits exactly the members named.\n\n\
Selection: a component is supported only when the comparison that adds that component alone favours it by AICc \
(by more than 2), its amplitude is determined (not at its bound, standard error under a third of the value; \
one k_s per incidence counts as one amplitude; for the directional or ideal diffuse an AICc gain over 10 also \
suffices, the note then says \"poorly determined\") AND it changes the prediction by more than 2 standard errors \
at some incidence. The selected model is the lowest-AICc member whose every component is supported (a lobe \
variant, GGX, Student-t or smooth k_s, takes the verdicts of its component set's Beckmann member); BIC's choice \
by the same rule is reported when it differs. By default each reading is weighed against its noise (--residual \
noise: a floor and a part proportional to the reading, from the readings' std/n, --noise or a stated rule), so \
the peak's few readings and the haze's many both count; goodness of fit, standard errors and the criteria all \
follow from that objective. When the sweep has std and n \
columns (gonio's captures do), the reduced chi-square against the readings' noise says whether a member fits \
within it, and the report says so plainly when none does.\n\n\
Each member is fitted on a log-spaced grid of lobe widths with its amplitudes solved linearly (non-negative) at \
every grid point, so a lobe one reading step wide is found, then refined by Levenberg–Marquardt with an \
analytic Jacobian; members are fitted in parallel. --fix holds a parameter at its value in every member that has \
it (a width held fixed is the grid's one width); a robust --loss refits each member from its least-squares \
optimum by iteratively reweighted least squares. Widths and amplitudes are fitted as their logarithms (a \
Student-t gamma as ln(gamma - 1)); standard errors come from the covariance at the optimum.\n\n\
When at least 3 readings equal the sweep's smallest value exactly, the report asks whether that is a \
detection floor; --floor auto leaves them out of the fit, --floor VALUE every reading at or below VALUE. When the \
measured specular peak sits off the selected member's peak at every incidence (0.1 degree or more, same side), \
the report says so (an angle offset or a tilted sample: --offset fit fits them); and when the selected core \
lobe is narrower at half maximum than the readings' step at the peak, that its width is not resolved. When the \
selected member's value at an incidence's highest reading is off by more than a factor 1.5 (or 3 of the noise's \
standard errors, where wider), the report names those incidences, the factor and the likely cause (a measured \
core off the mirror direction, or wider or narrower than the member's there); and it names a region (one \
incidence, or the detector angles toward grazing) whose residuals the member leaves on one side while another \
fitted member follows them.\n\n\
--aperture (or a `# aperture: DEG` line in the sweep) averages each model over the detector's acceptance cone \
before comparing, so widths are the surface's. With neither, where the readings do not resolve the core (the \
selected core narrower than the step, or a peak one reading 4x both neighbours) the family is refitted over an \
assumed half-angle of half the step and kept if its AICc is lower by more than 2; the report says so. \
--aperture 0 states point readings (nothing assumed). The RMSE table is the paper's Table 3: per incidence, curves \
normalised to their value at theta_r = theta_i, or at the nearest reading when there is none there (marked *). \
Angles in degrees, sigma_m in radians, BRDF in the file's units (its `# brdf:` line: relative, or 1/sr; \
--instrument fits in 1/sr). The report ends with physical checks of every model (none in a campaign unless \
--checks says so): the directional albedo rho(theta_i) at each incidence (rho > 1 in 1/sr is flagged \
non-physical) and the largest reciprocity ratio f(i->o)/f(o->i).",
    after_help = "Examples:\n  gonio fit fe.csv\n  gonio fit fe.csv --json > fe-fit.json\n  \
gonio fit fe.csv --instrument instrument.toml --plot plots/ --export merl=fe.binary --export json=fe-params.json\n  \
gonio fit fe.csv --fix sigma_m=0.7 --fix kdd=900 --loss cauchy:0.05\n  \
gonio fit metal.csv --models torrance-sparrow,specular:ggx+specular-haze+ideal-diffuse --aperture 0.5\n  \
gonio fit metal.csv --export residuals=metal-residuals.csv\n  \
gonio fit sweeps/ extra.csv --out reports/   (a campaign: reports/summary.csv)"
)]
pub struct FitArgs {
    /// The sweep file (CSV with columns theta_i, theta_r, brdf; see docs/formats.md). Several
    /// files, or directories (their *.csv files), make a campaign: every sweep fitted on
    /// all cores, one report each and a summary in --out.
    #[arg(value_name = "SWEEP.csv|DIR", required = true, num_args = 1..)]
    pub sweeps: Vec<PathBuf>,
    /// Campaign only: directory for the reports (one per sweep: NAME.txt, or NAME.json
    /// with --json) and summary.csv / summary.json.
    #[arg(long, value_name = "DIR", default_value = "gonio-fit")]
    pub out: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Print the whole report: every fitted member's parameters and criteria, the RMSE
    /// per incidence (the paper's Table 3) and the physical checks of every model. By
    /// default the report is the verdict: the selected member, its parameters, the fit
    /// against the noise and the notes, in at most 40 lines.
    #[arg(long, short = 'v')]
    pub all: bool,
    /// Write PNG and SVG plots of measured and fitted curves into DIR.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Export the selected (or --export-model) member, whatever its components, as
    /// brdf-core evaluates it: json=PATH (its --json entry, units, and its parameters
    /// as `member_table`), merl=PATH (MERL binary table of the reciprocal mean),
    /// csv=PATH (in-plane grid, 1-degree steps), residuals=PATH (CSV
    /// theta_i,theta_r,measured,fitted,residual per reading, in the file's order, the
    /// residual in --residual's kind), mitsuba=DIR (a Mitsuba 3 BSDF plugin, the
    /// model's parameters and a sphere scene: `python DIR/gonio_bsdf.py` renders it;
    /// needs `pip install ./python`), zemax=PATH (a Zemax tabular BSDF file with the TIS
    /// per incidence), astm=PATH (ASTM E1392-style rows over a hemisphere grid); merl,
    /// zemax and astm hold 1/sr: a relative fit needs --scale. Repeatable.
    #[arg(long, value_name = "FORMAT=PATH", value_parser = parse_export)]
    pub export: Vec<(ExportFormat, PathBuf)>,
    /// Overwrite existing --export and --plot files (never the sweep file itself, a
    /// device, a symlink or a directory).
    #[arg(long)]
    pub force: bool,
    /// The factor from a relative-unit fit to 1/sr (1/sr per relative unit, from a
    /// calibration) for the exports: those that hold 1/sr (merl, zemax, astm) refuse a
    /// relative fit without it; json says it; a mitsuba plugin renders with it.
    #[arg(long, value_name = "S", value_parser = parse_scale)]
    pub scale: Option<f64>,
    /// Which fitted model to export [default: the selected one]: a name as --models
    /// takes; any fitted member, whatever its components (a member the family did not
    /// fit can be fitted with --models).
    #[arg(long = "export-model", value_name = "MODEL", value_parser = fit::paper::member_by_name)]
    pub export_model: Option<Member>,
    /// Residuals to minimise.
    #[arg(long, value_enum, default_value_t = ResidualArg::Noise)]
    pub residual: ResidualArg,
    /// The instrument's noise for --residual noise: FLOOR,PROP, a floor in the file's
    /// brdf units and a fraction of each reading (e.g. 0.002,0.03); overrides the
    /// readings' std/n and the rule.
    #[arg(long, value_name = "FLOOR,PROP", value_parser = fit::NoiseModel::parse)]
    pub noise: Option<fit::NoiseModel>,
    /// Loss: l2, huber:C or cauchy:C (C in residual units, e.g. cauchy:0.05 for log
    /// residuals: readings off by more than ~5 % count less).
    #[arg(long, default_value = "l2", value_name = "LOSS", value_parser = Loss::parse)]
    pub loss: Loss,
    /// Hold a parameter fixed: sigma, sigma_m, kdd, kid, kd, or a :fresnel lobe's n or k
    /// (k may be 0: a dielectric), e.g. --fix sigma=0.115, --fix n=1.5 --fix k=0.
    /// Repeatable.
    #[arg(long = "fix", value_name = "NAME=VALUE")]
    pub fix: Vec<String>,
    /// Members to fit instead of the default family, comma-separated: the paper's names
    /// (ideal-diffuse, torrance-sparrow, three-component, three-component-smooth-ks, or
    /// their short forms ideal, ts, three, three-smooth) or systematic names, components
    /// joined by '+' (specular, specular-haze, directional-diffuse, ideal-diffuse), a
    /// lobe optionally with :beckmann, :ggx or :student-t (its tail exponent gamma fitted)
    /// and :smooth-ks or :fresnel (k_s = k0 F,
    /// the exact unpolarised Fresnel reflectance of index n + ik on the facet's local
    /// angle: k0, n in [0.02, 10] and k in [0, 15] fitted, or n, k held by --fresnel or
    /// --fix; only when named), e.g. specular:ggx+specular-haze+ideal-diffuse or
    /// specular:beckmann:fresnel+ideal-diffuse; or abg, the optics programs' ABg model
    /// (only when named; the report prints A, B, g for Zemax and FRED).
    #[arg(long, value_delimiter = ',', value_name = "MODELS", value_parser = fit::paper::member_by_name)]
    pub models: Vec<Member>,
    /// Hold every :fresnel lobe's n and k at a metal's tabulated optical constants at a
    /// wavelength in nm: al (Rakic 1995), cu, au, ag (Johnson & Christy 1972) or fe
    /// (Johnson & Christy 1974), 443-1127 nm, linear between the table's rows; e.g.
    /// --fresnel al@532. Needs --models with a :fresnel member; not with --fix n or k.
    #[arg(long, value_name = "METAL@NM")]
    pub fresnel: Option<String>,
    /// The detector's acceptance half-angle in degrees (0 to 10): every model is
    /// averaged over the detector's cone before it is compared with the readings, so
    /// the widths are the surface's. Overrides the sweep's `# aperture:` line; 0 states
    /// point readings (no aperture assumed for a core narrower than the step).
    #[arg(long, value_name = "DEG", value_parser = parse_aperture_arg)]
    pub aperture: Option<Aperture>,
    /// Fit in 1/sr: divide the (relative) readings by K from this instrument file
    /// (`gonio calibrate`); the report shows each amplitude's u(K) beside its fit
    /// uncertainty. Refused for a sweep already in 1/sr. With several sweeps (a
    /// campaign) every file is fitted in 1/sr, and the summary states u(K)/K, which
    /// every amplitude carries besides its fit uncertainty.
    #[arg(long, value_name = "instrument.toml")]
    pub instrument: Option<PathBuf>,
    /// Which fitted models the report's physical checks (albedo, reciprocity) cover.
    /// Default: every model for one sweep file; none in a campaign, where even one
    /// model's checks cost several times its fits (tens of ms of CPU per paper-grid
    /// file, mostly the albedo quadrature, against a few ms for all its fits).
    #[arg(long, value_enum, value_name = "WHICH")]
    pub checks: Option<ChecksArg>,
    /// Leave readings at or below a detection floor out of the fit: a value in the
    /// sweep file's brdf units (0 leaves out zero and negative readings), or `auto`: the
    /// sweep's smallest value when at least 3 readings equal it exactly (an
    /// instrument's floor or placeholder repeats to every digit; a measurement does not).
    /// Without it such readings are fitted, and the report asks whether they are a
    /// floor. The report, the JSON notes and the residuals export say how many were
    /// left out.
    #[arg(long, value_name = "auto|VALUE", value_parser = fit::data::parse_floor)]
    pub floor: Option<fit::Floor>,
    /// Refine every one of each member's best grid starts (up to 3; 8 for a member
    /// with a Student-t lobe) to its end. By
    /// default a start, or its LM path, that comes within two grid steps of every
    /// width of an optimum already reached, at no lower cost, is stopped there: the
    /// fit takes about half the time, but now and then misses a lower optimum (on 97
    /// test sweeps, simulated two-lobe and GGX surfaces among them, 12 of 886 member
    /// fits ended 0.1-30 % higher in SSR, mostly two-lobe members, and one sweep's
    /// selection changed).
    #[arg(long)]
    pub all_starts: bool,
    /// Fit the readings the capture flagged saturated (detector conversions at full
    /// scale: the values are clipped). By default they are left out and counted in a
    /// warning.
    #[arg(long)]
    pub keep_saturated: bool,
    /// The instrument's angles: `fit` fits a detector zero offset in theta_r and an
    /// in-plane sample tilt (which moves the mirror direction by twice the tilt and the
    /// local incidence by the tilt), each with a standard error, reported as
    /// instrument findings (where the data cannot tell them apart, all of the peak's
    /// shift is reported as a detector offset, and the report says so); a number is a
    /// known detector zero offset in degrees (the detector sits at theta_r - DEG when
    /// it reads theta_r). The fit is then of the readings at the sample's local angles.
    /// Default: the sweep's `# offset:` line, else none.
    #[arg(long, value_name = "fit|DEG", value_parser = fit::offset::OffsetSpec::parse)]
    pub offset: Option<fit::offset::OffsetSpec>,
    /// Add the appearance figures of the selected (or --export-model) member to the
    /// report: gloss at 20, 60, 85 degrees (ISO 2813 / ASTM D523), the D4039 haze index
    /// and E430's gloss, haze and DOI (see `gonio appearance`). Needs the fit in 1/sr
    /// (a sweep in 1/sr, --instrument) or --scale.
    #[arg(long)]
    pub appearance: bool,
}

/// `--aperture`'s value: a half-angle, or 0 (a point detector).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aperture(pub Option<f64>);

pub(super) fn parse_aperture_arg(s: &str) -> Result<Aperture, String> {
    fit::data::parse_aperture(s).map(Aperture)
}

/// The request the command line makes (the members `--models` names, if any, in
/// [`FitOptions::members`]; `--instrument` read), resolved with each sweep by
/// [`Request::job_for_file`].
pub fn request(args: &FitArgs) -> CliResult<Request> {
    let mut fixed = Fixed::default();
    for f in &args.fix {
        fixed.set(f).map_err(CliError::usage)?;
    }
    if let Some(spec) = &args.fresnel {
        let fresnel = |l: Option<brdf_core::member::LobeSpec>| {
            l.is_some_and(|l| l.ks == brdf_core::member::KsForm::Fresnel)
        };
        if !args
            .models
            .iter()
            .any(|m| fresnel(m.core) || fresnel(m.haze))
        {
            return Err(CliError::usage(
                "--fresnel holds a :fresnel lobe's n and k: name a member with one in --models (e.g. specular:beckmann:fresnel+ideal-diffuse)",
            ));
        }
        if fixed.n.is_some() || fixed.k.is_some() {
            return Err(CliError::usage(
                "--fresnel sets n and k: give it or --fix n=/k=, not both",
            ));
        }
        let (_, ix) = brdf_core::fresnel::metal(spec)
            .map_err(|e| CliError::usage(format!("--fresnel '{spec}': {e}")))?;
        (fixed.n, fixed.k) = (Some(ix.n), Some(ix.k));
    }
    if args.noise.is_some() && args.residual != ResidualArg::Noise {
        return Err(CliError::usage(
            "--noise states the noise of --residual noise: give both",
        ));
    }
    let residual = match args.residual {
        ResidualArg::Noise => Residual::Noise(args.noise.unwrap_or(fit::NoiseModel::FROM_DATA)),
        ResidualArg::Log => Residual::Log,
        ResidualArg::Rel => Residual::Relative,
        ResidualArg::Abs => Residual::Absolute,
    };
    let campaign = args.sweeps.len() > 1 || args.sweeps[0].is_dir();
    let checks = match args.checks {
        Some(ChecksArg::All) => CheckScope::All,
        Some(ChecksArg::Selected) => CheckScope::Selected,
        Some(ChecksArg::None) => CheckScope::None,
        None if campaign => CheckScope::None,
        None => CheckScope::All,
    };
    let mut fit = FitOptions {
        residual,
        loss: args.loss,
        fixed,
        floor: args.floor,
        all_starts: args.all_starts,
        keep_saturated: args.keep_saturated,
        checks,
        ..FitOptions::default()
    };
    if !args.models.is_empty() {
        fit.set_members(args.models.clone());
    }
    Ok(Request {
        fit,
        // --aperture wins over the sweep's line; 0 turns it off.
        aperture: args
            .aperture
            .map_or(RequestAperture::FromSweep, |a| RequestAperture::given(a.0)),
        offset: args.offset,
        instrument: None,
    })
}

/// An instrument file read, a bad one a usage error.
pub fn read_instrument(path: &std::path::Path) -> CliResult<InstrumentFile> {
    InstrumentFile::read(path).map_err(CliError::usage)
}
