//! `gonio budget`: the uncertainty budget of a sweep's fit (the law of propagation and
//! Monte Carlo over the instrument's error sources), as text or JSON.

use std::path::PathBuf;

use clap::Args;

use super::error::{CliError, CliResult};
use super::output::write_stdout;
use crate::calibrate::{Instrument, UncertaintyModel};
use crate::fit::physical::CheckScope;
use crate::fit::{FitOptions, NoiseModel, Residual};
use crate::request::{Aperture as RequestAperture, InstrumentFile, Request};
use crate::uncertainty::{Context, Sources, budget};

/// `gonio budget`.
#[derive(Debug, Args)]
#[command(
    about = "Uncertainty budget of a sweep's fit (GUM law of propagation and Monte Carlo)",
    long_about = "Fit a sweep as `gonio fit` does, then propagate the instrument's error sources to every reading, \
every fitted parameter of the selected member and the directional albedo at each incidence: by the law of \
propagation of uncertainty (JCGM 100; sensitivities from the fit's Jacobian) and by Monte Carlo (JCGM 101; each \
trial draws every source, perturbs the readings and refits the member from the fit's optimum). Where the two \
standard uncertainties differ by more than 10 % the budget uses Monte Carlo and says so. Expanded uncertainties \
at k = 2.\n\n\
Sources: reading noise (floor and proportional part, as the fit's noise model), the scale (K's u(K) from the \
instrument, or a stated scale for a sweep already in 1/sr), the reference's certificate (inside u(K) when K \
comes from `gonio calibrate`), detector linearity per decade, and each arm's step, backlash and home \
repeatability. They come from the instrument file's [uncertainty] table (or --uncertainty); every input it \
does not state is assumed, and the report names each assumption.",
    after_help = "Examples:\n  gonio budget sweep.csv --instrument inst.toml\n  \
gonio budget solar.sweep.csv --uncertainty solar-uncertainty.toml --trials 2000 --json"
)]
pub struct BudgetArgs {
    /// The sweep file.
    pub sweep: PathBuf,
    /// Instrument file (`gonio calibrate`'s): converts relative readings to 1/sr as
    /// `gonio fit --instrument`; its [uncertainty] table is the model unless
    /// --uncertainty is given.
    #[arg(long, value_name = "FILE")]
    pub instrument: Option<PathBuf>,
    /// The uncertainty model: a file with the [uncertainty] table's fields (or an
    /// instrument file).
    #[arg(long, value_name = "FILE")]
    pub uncertainty: Option<PathBuf>,
    /// Monte Carlo trials (0: the law of propagation alone).
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub trials: usize,
    /// Seed of the Monte Carlo draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The fit's objective: noise, log, rel or abs [default: the fit's].
    #[arg(long, value_name = "KIND")]
    pub residual: Option<String>,
    /// A detection floor (a value in the file's brdf units, or `auto`): readings at or
    /// below it are left out before the fit, as `gonio fit --floor`.
    #[arg(long, value_name = "VALUE|auto")]
    pub floor: Option<String>,
    /// The detector's half-angle, degrees: each reading is modelled as the average
    /// over that cone, as `gonio fit --aperture` (0: point readings). Without it (and
    /// without a `# aperture:` line) the fit assumes half the step where the readings
    /// do not resolve the core, and the budget lists that among its assumptions.
    #[arg(long, value_name = "DEG", value_parser = super::fit_args::parse_aperture_arg)]
    pub aperture: Option<super::fit_args::Aperture>,
    /// Add the appearance figures (specular gloss at 20, 60 and 85 deg, the D4039 haze
    /// index, E430 haze and DOI; see `gonio appearance`) to the outputs: they need the
    /// BRDF in 1/sr (a sweep in 1/sr, or --instrument).
    #[arg(long)]
    pub appearance: bool,
    /// Print every reading's expanded uncertainty (the JSON always holds them).
    #[arg(long)]
    pub per_reading: bool,
    /// JSON on stdout instead of the text report.
    #[arg(long)]
    pub json: bool,
}

/// The most Monte Carlo trials asked at once.
pub const MAX_TRIALS: usize = 1_000_000;

/// Runs `gonio budget`.
pub fn run(args: &BudgetArgs) -> CliResult {
    if args.trials > MAX_TRIALS {
        return Err(CliError::usage(format!(
            "--trials {}: at most {MAX_TRIALS}",
            args.trials
        )));
    }
    let instrument = match &args.instrument {
        Some(p) => Some(InstrumentFile::read(p).map_err(CliError::usage)?),
        None => None,
    };
    let model = match &args.uncertainty {
        Some(p) => UncertaintyModel::read(p).map_err(CliError::usage)?,
        None => instrument
            .as_ref()
            .and_then(|i| i.instrument.uncertainty.clone())
            .unwrap_or_default(),
    };
    let mut opts = FitOptions {
        checks: CheckScope::None,
        ..FitOptions::default()
    };
    if let Some(f) = &args.floor {
        opts.floor = Some(crate::fit::data::parse_floor(f).map_err(CliError::usage)?);
    }
    if let Some(r) = &args.residual {
        opts.residual = Residual::parse(r).map_err(CliError::usage)?;
    }
    let request = Request {
        fit: opts,
        instrument: instrument.clone(),
        aperture: args
            .aperture
            .map_or(RequestAperture::FromSweep, |a| RequestAperture::given(a.0)),
        ..Request::default()
    };
    let sf = super::fit::fit_file(&args.sweep, &request)?;
    let instrument: Option<Instrument> = instrument.map(|i| i.instrument);
    let fit = sf
        .family
        .selected_fit()
        .ok_or_else(|| CliError::failed("no member was fitted: no budget"))?;
    let data_noise = NoiseModel::of_data(&sf.data);
    let resolved = model.resolve(
        instrument.as_ref().map(|i| (i.k, i.u_k)),
        (data_noise.floor, data_noise.prop),
    );
    let sources = Sources::new(&resolved, instrument.is_some());
    let mut ctx = Context::new(&sf.data, fit, sf.residual, sources);
    if args.appearance {
        if sf.data.units != crate::sweep_file::BrdfUnits::PerSr {
            return Err(CliError::usage(
                "--appearance: gloss, haze and DOI need the BRDF in 1/sr but the sweep is in relative units: give --instrument FILE (or convert the sweep with gonio convert)",
            ));
        }
        ctx = ctx.with_appearance(1.0).map_err(CliError::failed)?;
    }
    let bar = indicatif::ProgressBar::new(args.trials as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:30} {pos}/{len} trials  {per_sec}  eta {eta}",
        )
        .expect("valid template"),
    );
    if args.trials == 0 {
        bar.finish_and_clear();
    }
    let mut assumptions = resolved.assumptions.clone();
    if sf.family.aperture_assumed
        && let Some(a) = sf.family.aperture
    {
        assumptions.push(format!(
            "detector aperture: a half-angle of {} deg assumed by the fit, the readings not resolving the core (its notes say how it was chosen), each reading modelled as the average over it; its uncertainty not propagated (state it with --aperture DEG)",
            crate::text::sig(a, 4)
        ));
    }
    if resolved.solid_angle.is_some() || resolved.beam_diameter.is_some() {
        assumptions.push(
            "solid angle and beam diameter: recorded, not propagated (the solid angle cancels in K, the reference being measured through the same aperture; the detector is assumed to see the whole beam footprint)".into(),
        );
    }
    let b = budget::compute(&ctx, args.trials, args.seed, assumptions, &|| bar.inc(1))
        .map_err(CliError::failed)?;
    bar.finish_and_clear();
    if args.json {
        let mut text = serde_json::to_string_pretty(&b.json()).expect("plain JSON");
        text.push('\n');
        write_stdout(text.as_bytes())
    } else {
        write_stdout(b.text(args.per_reading).as_bytes())
    }
}
