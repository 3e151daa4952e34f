//! What a fit is asked to do: the residual kind, the loss, parameters held fixed, and
//! the options of one fit ([`FitOptions`]); the one residual and robust weight of each.

use super::noise::NoiseModel;

/// What the residuals measure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Residual {
    /// g(f) - g(y) with g the variance-stabilising transform of a floor a and a
    /// proportional part b ([`NoiseModel::transform`]; slope 1 / sqrt(a^2 + (b y)^2):
    /// each reading against its standard error), its noise from the data
    /// ([`NoiseModel::of_data`]) unless stated. Readings well above a / b count as in log residuals
    /// (over b), those near the floor as in absolute ones (over a). The default.
    Noise(NoiseModel),
    /// ln f - ln y: every decade of the curve counts alike.
    Log,
    /// (f - y) / y.
    Relative,
    /// f - y, in the instrument's units.
    Absolute,
}

impl Residual {
    /// [`Residual::Noise`] with the noise from the data (`--residual noise`).
    pub const NOISE: Residual = Residual::Noise(NoiseModel::FROM_DATA);

    /// Parses `noise`, `log`, `rel` or `abs` (`gonio fit --residual`, Python's
    /// `residual=`).
    pub fn parse(s: &str) -> Result<Residual, String> {
        match s.trim() {
            "noise" => Ok(Residual::NOISE),
            "log" => Ok(Residual::Log),
            "rel" => Ok(Residual::Relative),
            "abs" => Ok(Residual::Absolute),
            _ => Err(format!(
                "--residual '{}': use noise, log, rel or abs",
                crate::text::escape_line(s, 40)
            )),
        }
    }

    /// The word in reports: `noise`, `log`, `rel` or `abs`.
    pub fn word(self) -> &'static str {
        match self {
            Residual::Noise(_) => "noise",
            Residual::Log => "log",
            Residual::Relative => "rel",
            Residual::Absolute => "abs",
        }
    }

    /// This kind with its noise model taken from `data` where it is to be
    /// ([`NoiseModel::resolved`]); the other kinds as they are.
    pub fn resolved(self, data: &super::data::Dataset) -> Residual {
        match self {
            Residual::Noise(m) => Residual::Noise(m.resolved(data)),
            other => other,
        }
    }

    /// The readings must be > 0: log and relative residuals divide by them, as does
    /// a noise model stated without a floor (its transform is then ln v / b). A noise
    /// model with a floor compares a reading at or below 0 against the floor, as
    /// `abs` does; so does one still to come from the data (its rule's floor is
    /// positive; one fitted to the readings' std without a floor is refused where it is
    /// resolved, [`super::job::prepare`]).
    pub fn needs_positive(self) -> bool {
        match self {
            Residual::Absolute => false,
            Residual::Noise(m) => m.from == super::noise::NoiseFrom::Stated && m.floor == 0.0,
            Residual::Log | Residual::Relative => true,
        }
    }
}

/// How residuals are penalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loss {
    /// Least squares.
    L2,
    /// Huber: quadratic within `c`, linear beyond (in residual units).
    Huber(f64),
    /// Cauchy: log(1 + (r/c)^2); outliers far beyond `c` barely count.
    Cauchy(f64),
}

/// How the family compared its models with the readings.
#[derive(Debug, Clone, Copy)]
pub struct Compared {
    /// The residual kind minimised.
    pub residual: Residual,
    /// The loss minimised.
    pub loss: Loss,
    /// The detector's aperture half-angle the models were averaged over (degrees).
    pub aperture: Option<f64>,
}

/// Options of a fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Residual kind.
    pub residual: Residual,
    /// Loss.
    pub loss: Loss,
    /// Parameters held fixed.
    pub fixed: Fixed,
    /// The family's members to fit (`None`: the default family, see
    /// [`super::family::default_members`]). Set by `gonio fit --models`.
    pub members: Option<Vec<brdf_core::member::Member>>,
    /// The detector's acceptance half-angle (degrees): the model is averaged over it
    /// before it is compared with the readings (`gonio fit --aperture`).
    pub aperture: Option<f64>,
    /// Which fitted models the reports' physical checks cover (`gonio fit --checks`).
    pub checks: CheckScope,
    /// A detection floor: readings at or below it are left out of the data before the
    /// fit (`gonio fit --floor`; see [`super::data::Floor`]).
    pub floor: Option<super::data::Floor>,
    /// Refine every one of a member's best grid starts to its end (`gonio fit
    /// --all-starts`). By default a start, or the LM path from it, that comes within
    /// [`super::member_fit::BASIN`] grid steps (in every width) of an optimum already
    /// reached, at no lower cost, is stopped there: the default family fits in about
    /// half the time, but on 97 test sweeps (simulated two-lobe and GGX truths among
    /// them) 12 of 886 member fits missed a lower optimum that way. Only the width
    /// grid's starts are stopped early.
    pub all_starts: bool,
    /// Fit the readings the capture flagged saturated (the detector at full scale: the
    /// value is clipped) too (`gonio fit --keep-saturated`); by default they are left
    /// out, and counted in a warning.
    pub keep_saturated: bool,
    /// The instrument's angles: a detector zero offset given, or the offset and a
    /// sample tilt fitted (`gonio fit --offset`, or the sweep's `# offset:` line).
    pub offset: Option<super::data::OffsetSpec>,
}

impl FitOptions {
    /// Fit exactly `members` (`--models`), each once, in the lattice's order.
    pub fn set_members(&mut self, mut members: Vec<brdf_core::member::Member>) {
        members.sort();
        members.dedup();
        self.members = Some(members);
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            residual: Residual::NOISE,
            loss: Loss::L2,
            fixed: Fixed::default(),
            members: None,
            aperture: None,
            checks: CheckScope::All,
            floor: None,
            all_starts: false,
            keep_saturated: false,
            offset: None,
        }
    }
}

/// One residual of the given kind (a [`Residual::Noise`] resolved: see
/// [`Residual::resolved`]).
pub fn residual_of(kind: Residual, f: f64, y: f64) -> f64 {
    match kind {
        Residual::Noise(m) => m.transform(f) - m.transform(y),
        Residual::Log => f.max(1e-300).ln() - y.ln(),
        Residual::Relative => f / y - 1.0,
        Residual::Absolute => f - y,
    }
}

impl Loss {
    /// Parses `l2`, `huber:C` or `cauchy:C` (`gonio fit --loss`, Python's `loss=`).
    pub fn parse(s: &str) -> Result<Loss, String> {
        let scale = |c: &str| -> Result<f64, String> {
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
                _ => Err(format!("--loss {s}: the scale must be a number > 0")),
            }
        };
        match s.split_once(':') {
            None if s == "l2" => Ok(Loss::L2),
            Some(("huber", c)) => Ok(Loss::Huber(scale(c)?)),
            Some(("cauchy", c)) => Ok(Loss::Cauchy(scale(c)?)),
            _ => Err(format!("--loss '{s}': use l2, huber:C or cauchy:C")),
        }
    }

    /// The IRLS weight of a residual `r` under this loss (1 for least squares).
    pub fn weight(self, r: f64) -> f64 {
        robust_weight(self, r)
    }
}

fn robust_weight(loss: Loss, r: f64) -> f64 {
    match loss {
        Loss::L2 => 1.0,
        Loss::Huber(c) => {
            if r.abs() <= c {
                1.0
            } else {
                c / r.abs()
            }
        }
        Loss::Cauchy(c) => 1.0 / (1.0 + (r / c) * (r / c)),
    }
}

/// The fit's box bounds of a lobe width sigma (radians; natural units).
pub const SIGMA_BOUNDS: (f64, f64) = (1e-4, 20.0);

/// The fit's box bounds of sigma_m (radians).
pub const SIGMA_M_BOUNDS: (f64, f64) = (1e-3, 20.0);

/// The fit's box bounds of every amplitude (k_s, k_dd, k_id; the data's units).
pub const AMPLITUDE_BOUNDS: (f64, f64) = (1e-12, 1e12);

/// The fit's box bounds of a Fresnel k_s's n: below a good metal's (silver's 0.03 at
/// 756 nm, the table's least) to a semiconductor's.
pub const FRESNEL_N_BOUNDS: (f64, f64) = (0.02, 10.0);

/// The fit's box bounds of a Fresnel k_s's k: from a dielectric's 0 past aluminium's
/// 11 at 1.1 um.
pub const FRESNEL_K_BOUNDS: (f64, f64) = (0.0, 15.0);

/// Parameters held fixed (`--fix name=value`), in natural units.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Fixed {
    /// sigma.
    pub sigma: Option<f64>,
    /// sigma_m.
    pub sigma_m: Option<f64>,
    /// k_dd.
    pub kdd: Option<f64>,
    /// k_id.
    pub kid: Option<f64>,
    /// k_d (the Torrance–Sparrow constant).
    pub kd: Option<f64>,
    /// A Fresnel k_s's n (every Fresnel lobe's; `--fresnel METAL@NM` sets n and k).
    pub n: Option<f64>,
    /// A Fresnel k_s's k.
    pub k: Option<f64>,
}

impl Fixed {
    /// Parses `name=value` (names: sigma, sigma_m, kdd, kid, kd, n, k; also k_dd, k_id,
    /// k_d). Every value must be > 0 but k's, which may be 0 (a dielectric).
    pub fn set(&mut self, spec: &str) -> Result<(), String> {
        let (name, value) = spec
            .split_once('=')
            .ok_or_else(|| format!("--fix '{spec}': expected NAME=VALUE"))?;
        let v: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("--fix '{spec}': '{value}' is not a number"))?;
        let k = name.trim() == "k";
        if !(v.is_finite() && (v > 0.0 || k && v == 0.0)) {
            let floor = if k { ">= 0" } else { "> 0" };
            return Err(format!(
                "--fix '{spec}': the value must be finite and {floor}"
            ));
        }
        // The fit's box bounds: a value outside them could not be held where it was
        // asked.
        let (lo, hi) = match name.trim() {
            "sigma" => SIGMA_BOUNDS,
            "sigma_m" | "sigma-m" => SIGMA_M_BOUNDS,
            "n" => FRESNEL_N_BOUNDS,
            "k" => FRESNEL_K_BOUNDS,
            _ => AMPLITUDE_BOUNDS,
        };
        if !(lo..=hi).contains(&v) {
            return Err(format!(
                "--fix '{spec}': the value must lie within [{lo:e}, {hi:e}], the fit's bounds for it"
            ));
        }
        let slot = match name.trim() {
            "sigma" => &mut self.sigma,
            "sigma_m" | "sigma-m" => &mut self.sigma_m,
            "kdd" | "k_dd" => &mut self.kdd,
            "kid" | "k_id" => &mut self.kid,
            "kd" | "k_d" => &mut self.kd,
            "n" => &mut self.n,
            "k" => &mut self.k,
            other => {
                return Err(format!(
                    "--fix: unknown parameter '{other}' (sigma, sigma_m, kdd, kid, kd, n, k)"
                ));
            }
        };
        *slot = Some(v);
        Ok(())
    }
}

/// Which fitted models the physical checks cover (`gonio fit --checks`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CheckScope {
    /// Every fitted model (the default for one sweep file).
    #[default]
    All,
    /// The selected model only.
    Selected,
    /// None (a campaign's default: checking even one model costs several times the fits
    /// of a small sweep, mostly the albedo quadrature).
    None,
}

impl CheckScope {
    /// The word in reports and JSON: `all` or `selected`.
    pub fn word(self) -> &'static str {
        match self {
            CheckScope::All => "all",
            CheckScope::Selected => "selected",
            CheckScope::None => "none",
        }
    }
}
