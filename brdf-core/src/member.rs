//! The model family's members: which components are on, the fixed vocabulary of
//! component and distribution names, and the systematic name of every member.
//!
//! A name is the paper's where the member is one of the paper's (`ideal-diffuse`,
//! `torrance-sparrow`, `three-component`, `three-component-smooth-ks`), otherwise the
//! components joined by `+` in the fixed order specular, specular-haze,
//! directional-diffuse, ideal-diffuse; a lobe carries its distribution after `:` and,
//! when its k_s is the smooth k_s(theta_i), `:smooth-ks`, when it is k0 times the
//! Fresnel reflectance on the facet's local angle, `:fresnel`. For example
//! `specular:ggx+specular-haze:beckmann+ideal-diffuse` or
//! `specular:beckmann:smooth-ks+directional-diffuse+ideal-diffuse`. `:student-t` (a
//! Student-t lobe with a tail exponent gamma) is a name in no lattice. The optics
//! programs' ABg model ([`crate::abg`]) is the member `abg`, alone: it is a whole
//! scatter model of its own, not a part of the paper's family, so it is in no lattice
//! and is fitted when asked for.

use core::fmt;

use crate::lobe::Distribution;

/// One component of the family; [`Component::name`] is its vocabulary name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Component {
    /// The core specular lobe (`specular`).
    Specular,
    /// A second, usually wider, specular lobe with its own width (`specular-haze`).
    SpecularHaze,
    /// The directional diffuse Gaussian in theta_r, eq. 5 (`directional-diffuse`).
    DirectionalDiffuse,
    /// The ideal (uniform) diffuse term, eq. 6 (`ideal-diffuse`).
    IdealDiffuse,
    /// The optics programs' ABg model ([`crate::abg`], `abg`); a member on its own.
    Abg,
}

impl Component {
    /// The vocabulary, in name order.
    pub const ALL: [Component; 5] = [
        Component::Specular,
        Component::SpecularHaze,
        Component::DirectionalDiffuse,
        Component::IdealDiffuse,
        Component::Abg,
    ];

    /// The vocabulary name.
    pub fn name(self) -> &'static str {
        match self {
            Component::Specular => "specular",
            Component::SpecularHaze => "specular-haze",
            Component::DirectionalDiffuse => "directional-diffuse",
            Component::IdealDiffuse => "ideal-diffuse",
            Component::Abg => "abg",
        }
    }

    /// The component of a vocabulary name.
    pub fn parse(name: &str) -> Option<Self> {
        Component::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// How a specular lobe's weight k_s depends on the incidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum KsForm {
    /// One k_s per incidence, supplied by the caller for the reading's theta_i (the paper).
    PerIncidence,
    /// `ln k_s = c0 + c1 t + c2 t^2`, t = theta_i / 90 ([`crate::lobe::SmoothKs`]).
    Smooth,
    /// `k_s = k0 F(beta; n, k)`: the exact unpolarised Fresnel reflectance
    /// ([`crate::fresnel`]) at the facet's local angle beta (between w_i and the half
    /// vector), of a conductor n + ik or a dielectric (k = 0)
    /// ([`crate::member_model::FresnelKs`]).
    Fresnel,
}

impl KsForm {
    /// The name used in reports: `per-incidence`, `smooth` or `fresnel` (in member
    /// names the smooth form is the suffix `:smooth-ks`, the Fresnel form `:fresnel`,
    /// the per-incidence form is the default).
    pub fn name(self) -> &'static str {
        match self {
            KsForm::PerIncidence => "per-incidence",
            KsForm::Smooth => "smooth",
            KsForm::Fresnel => "fresnel",
        }
    }

    /// The suffix of this form in member names (`""` for the default, per incidence).
    pub fn suffix(self) -> &'static str {
        match self {
            KsForm::PerIncidence => "",
            KsForm::Smooth => ":smooth-ks",
            KsForm::Fresnel => ":fresnel",
        }
    }
}

/// The shape of one specular lobe in a member: its distribution and its k_s form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LobeSpec {
    /// The slope distribution.
    pub dist: Distribution,
    /// The k_s form.
    pub ks: KsForm,
}

impl LobeSpec {
    /// The paper's lobe: Beckmann, one k_s per incidence.
    pub const PAPER: LobeSpec = LobeSpec {
        dist: Distribution::Beckmann,
        ks: KsForm::PerIncidence,
    };

    /// Every lobe shape (2 distributions x 2 k_s forms).
    pub const ALL: [LobeSpec; 4] = [
        LobeSpec::PAPER,
        LobeSpec {
            dist: Distribution::Beckmann,
            ks: KsForm::Smooth,
        },
        LobeSpec {
            dist: Distribution::Ggx,
            ks: KsForm::PerIncidence,
        },
        LobeSpec {
            dist: Distribution::Ggx,
            ks: KsForm::Smooth,
        },
    ];
}

/// A member of the family: which components are on and the shape of each lobe.
/// Valid when a haze lobe comes with a core lobe and at least one component is on
/// ([`Member::is_valid`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Member {
    /// The core specular lobe, if on.
    pub core: Option<LobeSpec>,
    /// The haze lobe, if on (needs `core`).
    pub haze: Option<LobeSpec>,
    /// The directional diffuse term (eq. 5).
    pub directional: bool,
    /// The ideal diffuse term (eq. 6).
    pub ideal: bool,
    /// The ABg model ([`crate::abg`]); valid only alone.
    pub abg: bool,
}

/// Why a member name was not understood. Prints one line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NameError {
    /// A `+`-separated part is not a component of the vocabulary.
    UnknownComponent,
    /// A `:` attribute is neither a distribution nor `smooth-ks` or `fresnel`, or
    /// sits on a component without a lobe (or a lobe has two k_s forms).
    BadAttribute,
    /// A component appears twice.
    Repeated,
    /// The combination is not a member (a haze without a core lobe, or nothing on).
    Invalid,
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NameError::UnknownComponent => {
                "unknown component (known: specular, specular-haze, directional-diffuse, ideal-diffuse, abg, or a paper name: ideal-diffuse, torrance-sparrow, three-component, three-component-smooth-ks)"
            }
            NameError::BadAttribute => {
                "bad lobe attribute (a lobe takes :beckmann, :ggx or :student-t and optionally :smooth-ks or :fresnel)"
            }
            NameError::Repeated => "a component is named twice",
            NameError::Invalid => {
                "not a member: specular-haze needs specular, abg stands alone, and at least one component must be on"
            }
        })
    }
}

impl core::error::Error for NameError {}

impl Member {
    /// f = k_id.
    pub const IDEAL_DIFFUSE: Member = Member {
        core: None,
        haze: None,
        directional: false,
        ideal: true,
        abg: false,
    };
    /// Torrance–Sparrow: the paper's lobe plus a constant.
    pub const TORRANCE_SPARROW: Member = Member {
        core: Some(LobeSpec::PAPER),
        haze: None,
        directional: false,
        ideal: true,
        abg: false,
    };
    /// The paper's three components, one k_s per incidence.
    pub const THREE_COMPONENT: Member = Member {
        core: Some(LobeSpec::PAPER),
        haze: None,
        directional: true,
        ideal: true,
        abg: false,
    };
    /// The paper's three components with the smooth k_s(theta_i).
    pub const THREE_COMPONENT_SMOOTH_KS: Member = Member {
        core: Some(LobeSpec {
            dist: Distribution::Beckmann,
            ks: KsForm::Smooth,
        }),
        haze: None,
        directional: true,
        ideal: true,
        abg: false,
    };

    /// The ABg model alone.
    pub const ABG: Member = Member {
        core: None,
        haze: None,
        directional: false,
        ideal: false,
        abg: true,
    };

    /// The paper's members and their names, simplest first.
    pub const PAPER: [(&'static str, Member); 4] = [
        ("ideal-diffuse", Member::IDEAL_DIFFUSE),
        ("torrance-sparrow", Member::TORRANCE_SPARROW),
        ("three-component", Member::THREE_COMPONENT),
        (
            "three-component-smooth-ks",
            Member::THREE_COMPONENT_SMOOTH_KS,
        ),
    ];

    /// Longest name of any member, in bytes (for fixed-capacity strings).
    pub const MAX_NAME_LEN: usize = 96;

    /// Valid: a haze comes with a core lobe, ABg stands alone, and at least one
    /// component is on.
    pub fn is_valid(&self) -> bool {
        if self.abg {
            return *self == Member::ABG;
        }
        (self.haze.is_none() || self.core.is_some())
            && (self.core.is_some() || self.directional || self.ideal)
    }

    /// Whether a component is on.
    pub fn has(&self, c: Component) -> bool {
        match c {
            Component::Specular => self.core.is_some(),
            Component::SpecularHaze => self.haze.is_some(),
            Component::DirectionalDiffuse => self.directional,
            Component::IdealDiffuse => self.ideal,
            Component::Abg => self.abg,
        }
    }

    /// The components that are on, in vocabulary order.
    pub fn components(&self) -> impl Iterator<Item = Component> + '_ {
        Component::ALL.into_iter().filter(|&c| self.has(c))
    }

    /// The same member with component `c` off (the haze goes with the core, since a
    /// haze alone is not a member). May be invalid (e.g. nothing left on).
    pub fn without(&self, c: Component) -> Member {
        let mut m = *self;
        match c {
            Component::Specular => {
                m.core = None;
                m.haze = None;
            }
            Component::SpecularHaze => m.haze = None,
            Component::DirectionalDiffuse => m.directional = false,
            Component::IdealDiffuse => m.ideal = false,
            Component::Abg => m.abg = false,
        }
        m
    }

    /// The paper's name of this member, if it is one of the paper's.
    pub fn paper_name(&self) -> Option<&'static str> {
        Member::PAPER
            .iter()
            .find(|(_, m)| m == self)
            .map(|&(name, _)| name)
    }

    /// The member's name (see the module docs); the same text as `Display`.
    pub fn name(&self) -> heapless::String<{ Member::MAX_NAME_LEN }> {
        let mut s = heapless::String::new();
        // Cannot fail: the longest name is shorter than MAX_NAME_LEN (tested).
        let _ = fmt::write(&mut s, format_args!("{self}"));
        s
    }

    /// Parses a paper name or a systematic name (parts in any order; a lobe without
    /// `:dist` is Beckmann, without `:smooth-ks` has k_s per incidence).
    pub fn parse(name: &str) -> Result<Member, NameError> {
        let name = name.trim();
        if let Some(&(_, m)) = Member::PAPER.iter().find(|(n, _)| *n == name) {
            return Ok(m);
        }
        let mut m = Member {
            core: None,
            haze: None,
            directional: false,
            ideal: false,
            abg: false,
        };
        let mut seen = [false; Component::ALL.len()];
        for part in name.split('+') {
            let mut attrs = part.trim().split(':');
            let head = attrs.next().unwrap_or("");
            let c = Component::parse(head).ok_or(NameError::UnknownComponent)?;
            let slot = &mut seen[c as usize];
            if *slot {
                return Err(NameError::Repeated);
            }
            *slot = true;
            let mut lobe = LobeSpec::PAPER;
            let mut any = false;
            for a in attrs {
                any = true;
                if let Some(d) = Distribution::parse(a) {
                    lobe.dist = d;
                } else if let Some(form) = [KsForm::Smooth, KsForm::Fresnel]
                    .into_iter()
                    .find(|f| f.suffix().strip_prefix(':') == Some(a))
                {
                    if lobe.ks != KsForm::PerIncidence {
                        return Err(NameError::BadAttribute);
                    }
                    lobe.ks = form;
                } else {
                    return Err(NameError::BadAttribute);
                }
            }
            match c {
                Component::Specular => m.core = Some(lobe),
                Component::SpecularHaze => m.haze = Some(lobe),
                _ if any => return Err(NameError::BadAttribute),
                Component::DirectionalDiffuse => m.directional = true,
                Component::IdealDiffuse => m.ideal = true,
                Component::Abg => m.abg = true,
            }
        }
        if m.is_valid() {
            Ok(m)
        } else {
            Err(NameError::Invalid)
        }
    }

    /// Every valid member of the paper's family (83 of them; not [`Member::ABG`]), in a fixed order: the lattice the fitter chooses
    /// from.
    pub fn lattice() -> impl Iterator<Item = Member> {
        const LOBES: [Option<LobeSpec>; 5] = [
            None,
            Some(LobeSpec::ALL[0]),
            Some(LobeSpec::ALL[1]),
            Some(LobeSpec::ALL[2]),
            Some(LobeSpec::ALL[3]),
        ];
        LOBES.into_iter().flat_map(|core| {
            LOBES.into_iter().flat_map(move |haze| {
                [(false, false), (false, true), (true, false), (true, true)]
                    .into_iter()
                    .map(move |(directional, ideal)| Member {
                        core,
                        haze,
                        directional,
                        ideal,
                        abg: false,
                    })
                    .filter(Member::is_valid)
            })
        })
    }
}

impl fmt::Display for Member {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(name) = self.paper_name() {
            return f.write_str(name);
        }
        let mut first = true;
        for c in self.components() {
            if !first {
                f.write_str("+")?;
            }
            first = false;
            f.write_str(c.name())?;
            let lobe = match c {
                Component::Specular => self.core,
                Component::SpecularHaze => self.haze,
                _ => None,
            };
            if let Some(l) = lobe {
                write!(f, ":{}{}", l.dist.name(), l.ks.suffix())?;
            }
        }
        if first {
            f.write_str("none")?;
        }
        Ok(())
    }
}
