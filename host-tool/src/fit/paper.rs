//! The paper's four members by name ([`Kind`]: what the user types, what reports and
//! figures say) and members by name for `--models`; their fits are members like any
//! other ([`super::member_fit::MemberFit`]).

use brdf_core::Components;
use brdf_core::member::Member;

/// The models fitted, from the simplest up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    /// Ideal diffuse only: f = k_id.
    IdealDiffuse,
    /// Torrance–Sparrow: f = k_s(theta_i) f_s + k_d, one k_s per incidence.
    TorranceSparrow,
    /// Three components, one k_s per incidence (as the paper fits it).
    ThreeComponent,
    /// Three components with ln k_s a quadratic in theta_i/90 (3 parameters).
    ThreeSmooth,
}

impl Kind {
    /// All kinds, simplest first.
    pub const ALL: [Kind; 4] = [
        Kind::IdealDiffuse,
        Kind::TorranceSparrow,
        Kind::ThreeComponent,
        Kind::ThreeSmooth,
    ];

    /// Every name of this model (its row of the vocabulary table).
    pub const fn names(self) -> Names {
        match self {
            Kind::IdealDiffuse => Names {
                cli: "ideal",
                report: "ideal-diffuse",
                figure: "ideal diffuse",
                help: "f = k_id.",
            },
            Kind::TorranceSparrow => Names {
                cli: "ts",
                report: "torrance-sparrow",
                figure: "Torrance–Sparrow",
                help: "Torrance–Sparrow: k_s(theta_i) f_s + k_d.",
            },
            Kind::ThreeComponent => Names {
                cli: "three",
                report: "three-component",
                figure: "three-component",
                help: "Three components: k_s f_s + k_dd f_dd + k_id (eq. 2), one k_s per incidence.",
            },
            Kind::ThreeSmooth => Names {
                cli: "three-smooth",
                report: "three-component-smooth-ks",
                figure: "three-component, smooth k_s",
                help: "Three components, ln k_s quadratic in theta_i.",
            },
        }
    }

    /// The member of brdf-core's component lattice this kind is (its report name is the
    /// member's paper name).
    pub const fn member(self) -> Member {
        match self {
            Kind::IdealDiffuse => Member::IDEAL_DIFFUSE,
            Kind::TorranceSparrow => Member::TORRANCE_SPARROW,
            Kind::ThreeComponent => Member::THREE_COMPONENT,
            Kind::ThreeSmooth => Member::THREE_COMPONENT_SMOOTH_KS,
        }
    }

    /// The canonical name, used in reports, JSON and messages.
    pub const fn name(self) -> &'static str {
        self.names().report
    }

    /// The kind whose command-line name is `cli`.
    pub fn from_cli_name(cli: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.names().cli == cli)
    }

    /// The components it switches on.
    pub fn components(self) -> Components {
        match self {
            Kind::IdealDiffuse => Components {
                specular: false,
                directional: false,
                ideal: true,
            },
            Kind::TorranceSparrow => Components::TORRANCE_SPARROW,
            Kind::ThreeComponent | Kind::ThreeSmooth => Components::ALL,
        }
    }

    /// Has a specular lobe.
    pub fn specular(self) -> bool {
        self.components().specular
    }

    /// Has the directional-diffuse lobe.
    pub fn directional(self) -> bool {
        self.components().directional
    }
}

/// The names of one model: what the user types, what reports, JSON and messages say,
/// what figures say, and its one-line description. Every one of them comes from
/// [`Kind::names`], the single table of this vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Names {
    /// On the command line (`fit --models`, `fit --export-model`, `eval --model`).
    pub cli: &'static str,
    /// Canonical: reports, JSON, messages.
    pub report: &'static str,
    /// Figure titles and legends.
    pub figure: &'static str,
    /// One line for `--help`.
    pub help: &'static str,
}

/// A member by name: a paper name, its short form (`ideal`, `ts`, `three`,
/// `three-smooth`), or a systematic name (see [`Member::parse`]); for `gonio fit
/// --models` and Python's `models=`.
pub fn member_by_name(s: &str) -> Result<Member, String> {
    let t = s.trim();
    if let Some(k) = Kind::from_cli_name(t) {
        return Ok(k.member());
    }
    Member::parse(t).map_err(|e| format!("'{}': {e}", crate::text::escape_line(s, 60)))
}

/// A lobe's tail exponent given by `flag` (`--gamma` to `gonio eval`, `gamma=` to
/// Python's `Model`), for members built by hand: required for a Student-t lobe,
/// refused for a lobe without one; the value itself is brdf-core's to check (finite,
/// > 1). `what` names the lobe in the message.
pub fn lobe_tail(
    what: &str,
    flag: &str,
    dist: brdf_core::lobe::Distribution,
    given: Option<f64>,
) -> Result<Option<f64>, String> {
    match (dist.has_gamma(), given) {
        (true, None) => Err(format!(
            "{what} is student-t: give its tail exponent with {flag} (> 1; GGX's tail at 2)"
        )),
        (false, Some(_)) => Err(format!(
            "{flag} is the tail exponent of a student-t lobe; {what} is {}",
            dist.name()
        )),
        (_, g) => Ok(g),
    }
}

/// The [`Kind`] of a paper member.
pub fn kind_of(m: brdf_core::member::Member) -> Option<Kind> {
    Kind::ALL.into_iter().find(|k| k.member() == m)
}
