//! `--until PARAM:REL[,PARAM:REL...]`: the targets on the selected member's relative
//! standard errors at which a capture has measured enough, and whether an online
//! estimate ([`crate::fit::online::Estimate`]) meets them.

use std::fmt;

use crate::fit::online::Estimate;

/// The parameters a target may name: the fit report's names of the scalar parameters.
pub const PARAMS: [&str; 5] = ["sigma", "sigma_haze", "sigma_m", "k_dd", "k_id"];

/// Other spellings accepted (those `--fix` takes, and the Torrance–Sparrow `k_d`).
const ALIASES: [(&str, &str); 6] = [
    ("sigma-haze", "sigma_haze"),
    ("sigma-m", "sigma_m"),
    ("kdd", "k_dd"),
    ("kid", "k_id"),
    ("k_d", "k_id"),
    ("kd", "k_id"),
];

/// One target: parameter `name`'s standard error at most `rel` times its value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// The report name ([`PARAMS`]).
    pub name: &'static str,
    /// The relative standard error wanted (0.02 = 2 %).
    pub rel: f64,
}

/// Every target of `--until`; met when all are.
#[derive(Debug, Clone, PartialEq)]
pub struct Until(pub Vec<Target>);

/// How one target stands in an estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Standing {
    /// The target.
    pub target: Target,
    /// The relative standard error now (`None`: the selected member lacks the
    /// parameter, or the data do not determine it: not met).
    pub rel_se: Option<f64>,
}

impl Standing {
    /// The target is met.
    pub fn met(&self) -> bool {
        self.rel_se.is_some_and(|r| r <= self.target.rel)
    }
}

impl Until {
    /// Parses `sigma:2%,k_id:5%` (REL as a percentage or a fraction: `2%` or `0.02`,
    /// above 0 and at most 100 %). Unknown names are refused naming the valid ones.
    pub fn parse(s: &str) -> Result<Until, String> {
        let bad = |why: String| format!("--until '{}': {why}", crate::text::escape_line(s, 60));
        let mut targets: Vec<Target> = Vec::new();
        for part in s.split(',') {
            let (name, rel) = part
                .split_once(':')
                .ok_or_else(|| bad(format!("'{}' is not PARAM:REL", part.trim())))?;
            let name = name.trim();
            let canon = PARAMS
                .iter()
                .copied()
                .find(|p| *p == name)
                .or_else(|| ALIASES.iter().find(|(a, _)| *a == name).map(|(_, p)| *p))
                .ok_or_else(|| {
                    bad(format!(
                        "unknown parameter '{name}' (valid: {}; also kdd, kid, k_d, kd, sigma-m, sigma-haze)",
                        PARAMS.join(", ")
                    ))
                })?;
            let rel = rel.trim();
            let value = match rel.strip_suffix('%') {
                Some(p) => p.trim().parse::<f64>().map(|v| v / 100.0),
                None => rel.parse::<f64>(),
            }
            .map_err(|_| bad(format!("'{rel}' is not a relative error (e.g. 2% or 0.02)")))?;
            if !(value > 0.0 && value <= 1.0) {
                return Err(bad(format!(
                    "{name}: the relative error must be above 0 and at most 100% (got {rel})"
                )));
            }
            if targets.iter().any(|t| t.name == canon) {
                return Err(bad(format!("{canon} is given twice")));
            }
            targets.push(Target {
                name: canon,
                rel: value,
            });
        }
        Ok(Until(targets))
    }

    /// How each target stands in `est`.
    pub fn standing(&self, est: &Estimate) -> Vec<Standing> {
        self.0
            .iter()
            .map(|&target| Standing {
                target,
                rel_se: est.rel_se(target.name),
            })
            .collect()
    }

    /// Every target is met in `est`.
    pub fn met(&self, est: &Estimate) -> bool {
        self.standing(est).iter().all(Standing::met)
    }

    /// The standing of every target for people: `sigma 1.8 % (<= 2 %)`.
    pub fn describe(&self, est: &Estimate) -> String {
        self.standing(est)
            .iter()
            .map(|s| {
                let now = s.rel_se.map_or("not determined".to_string(), pct);
                let value = est.param(s.target.name).map_or(String::new(), |p| {
                    let v = crate::fit::report::fmt_se(p.value, p.se);
                    format!(" = {}", v.split_whitespace().collect::<Vec<_>>().join(" "))
                });
                format!(
                    "{}{value} ({now}, target {})",
                    s.target.name,
                    pct(s.target.rel)
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A fraction as a percentage: `1.8 %`.
fn pct(x: f64) -> String {
    format!("{:.2} %", x * 100.0)
}

impl fmt::Display for Until {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self
            .0
            .iter()
            .map(|t| format!("{}:{}%", t.name, t.rel * 100.0))
            .collect();
        f.write_str(&parts.join(","))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_with_aliases_and_percentages() {
        let u = Until::parse("sigma:2%,kid:0.05").unwrap();
        assert_eq!(
            u.0,
            vec![
                Target {
                    name: "sigma",
                    rel: 0.02
                },
                Target {
                    name: "k_id",
                    rel: 0.05
                }
            ]
        );
        assert_eq!(u.to_string(), "sigma:2%,k_id:5%");
        assert_eq!(
            Until::parse(" sigma-m : 10 % ").unwrap().0[0].name,
            "sigma_m"
        );
        for (bad, says) in [
            ("sigmaa:2%", "valid: sigma, sigma_haze, sigma_m, k_dd, k_id"),
            ("sigma", "not PARAM:REL"),
            ("sigma:x", "not a relative error"),
            ("sigma:0", "above 0"),
            ("sigma:150%", "at most 100%"),
            ("sigma:2%,sigma:3%", "twice"),
            ("", "not PARAM:REL"),
        ] {
            let e = Until::parse(bad).unwrap_err();
            assert!(e.starts_with("--until") && e.contains(says), "{bad}: {e}");
            assert!(!e.contains('\n'));
        }
    }

    #[test]
    fn a_target_is_met_only_when_determined_and_small_enough() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let rows = crate::fit::data::synthetic_paper_sweep(|t| fe.model(t).unwrap(), 0.005, 3);
        let mut online = crate::fit::online::OnlineFit::with_rows(rows);
        let est = online.refit().unwrap();
        let rel = est.rel_se("sigma").unwrap();
        assert!(
            Until::parse(&format!("sigma:{}", rel * 1.01))
                .unwrap()
                .met(est)
        );
        assert!(
            !Until::parse(&format!("sigma:{}", rel * 0.99))
                .unwrap()
                .met(est)
        );
        // A parameter the selected member lacks is never known.
        let lacks = PARAMS.iter().find(|p| est.param(p).is_none()).unwrap();
        let u = Until::parse(&format!("{lacks}:100%")).unwrap();
        assert!(!u.met(est));
        assert!(
            u.describe(est).contains("not determined"),
            "{}",
            u.describe(est)
        );
    }
}
