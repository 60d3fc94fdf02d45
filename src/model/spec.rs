//! Model specs such as `trilinear+lcfm+viscous`: which component of each
//! kind the model has, and which parameters that makes it need.

use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

use super::error::{ParamError, SpecError};
use super::params::{ParamName, Params};

/// The rubber-bearing spring.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpringKind {
    /// Never yields: `F = k0 u` (parameters `f0`).
    Linear,
    /// Bi-linear hysteresis (parameters `uy, f0, f1`).
    Bilinear,
    /// Tri-linear hysteresis (parameters `uy, f0, f1, f2, u3`).
    Trilinear,
}

/// The sliding-bearing friction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrictionKind {
    /// No slider.
    None,
    /// Constant Coulomb friction, CCFM (parameter `uF0`).
    Coulomb,
    /// Linear Coulomb friction, LCFM: amplitude `F_F0 + k_F |u|`
    /// (parameters `uF0, rF0`).
    Lcfm,
}

/// The viscous damper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DamperKind {
    /// No damper.
    None,
    /// Linear viscous damper (parameter `zeta0`).
    Viscous,
}

/// A member of the model family, named by a spec string.
///
/// ```
/// use hbis::model::ModelSpec;
/// let m: ModelSpec = "bilinear+coulomb".parse().unwrap();
/// assert_eq!(m.to_string(), "bilinear+coulomb");
/// let names: Vec<_> = m.param_names().iter().map(|p| p.as_str()).collect();
/// assert_eq!(names, ["u0", "uy", "uF0", "f0", "f1"]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ModelSpec {
    pub spring: SpringKind,
    pub friction: FrictionKind,
    pub damper: DamperKind,
}

impl ModelSpec {
    /// The paper's full model, `trilinear+lcfm+viscous`.
    pub const FULL: ModelSpec = ModelSpec {
        spring: SpringKind::Trilinear,
        friction: FrictionKind::Lcfm,
        damper: DamperKind::Viscous,
    };

    /// Whether the model uses parameter `p`.
    pub fn uses(&self, p: ParamName) -> bool {
        use ParamName::*;
        match p {
            U0 | F0 => true,
            Uy | F1 => self.spring != SpringKind::Linear,
            F2 | U3 => self.spring == SpringKind::Trilinear,
            UF0 => self.friction != FrictionKind::None,
            RF0 => self.friction == FrictionKind::Lcfm,
            Zeta0 => self.damper == DamperKind::Viscous,
        }
    }

    /// The parameters this model needs, in the paper's order.
    pub fn param_names(&self) -> Vec<ParamName> {
        ParamName::ALL
            .into_iter()
            .filter(|&p| self.uses(p))
            .collect()
    }

    fn names_list(&self) -> String {
        self.param_names()
            .iter()
            .map(|p| p.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Parameters from a name-value map: every needed name present, no
    /// other, all values valid.
    pub fn params_from_map(&self, map: &BTreeMap<ParamName, f64>) -> Result<Params, ParamError> {
        if let Some(&p) = map.keys().find(|&&p| !self.uses(p)) {
            return Err(ParamError::Unused {
                name: p.as_str(),
                model: self.to_string(),
                expected: self.names_list(),
            });
        }
        let mut out = Self::neutral();
        for p in self.param_names() {
            let v = *map.get(&p).ok_or(ParamError::Missing {
                name: p.as_str(),
                model: self.to_string(),
            })?;
            out.set(p, v);
        }
        self.finish(out)
    }

    /// Parameters from values in the order of [`ModelSpec::param_names`].
    pub fn params_from_slice(&self, theta: &[f64]) -> Result<Params, ParamError> {
        // No allocation: this runs once per posterior evaluation.
        let expected = self.used().count();
        if theta.len() != expected {
            return Err(ParamError::Length {
                model: self.to_string(),
                expected,
                found: theta.len(),
            });
        }
        let mut out = Self::neutral();
        for (p, &v) in self.used().zip(theta) {
            out.set(p, v);
        }
        self.finish(out)
    }

    /// The parameters this model needs, in the paper's order, without
    /// allocating.
    pub fn used(&self) -> impl Iterator<Item = ParamName> + '_ {
        ParamName::ALL.into_iter().filter(move |&p| self.uses(p))
    }

    /// Keep only what this model uses from a full parameter set (the rest set
    /// to the values that make their components vanish), then validate.
    pub fn restrict(&self, full: &Params) -> Result<Params, ParamError> {
        let mut out = Self::neutral();
        for p in self.param_names() {
            out.set(p, full.get(p));
        }
        self.finish(out)
    }

    /// Values that make unused components vanish; `f2`, `u3` follow later.
    fn neutral() -> Params {
        Params {
            u0: 0.0,
            uy: f64::INFINITY,
            uf0: 0.0,
            rf0: 0.0,
            zeta0: 0.0,
            f0: 1.0,
            f1: 0.0,
            f2: 0.0,
            u3: f64::INFINITY,
        }
    }

    fn finish(&self, mut p: Params) -> Result<Params, ParamError> {
        match self.spring {
            SpringKind::Linear => {
                p.f1 = p.f0;
                p.f2 = p.f0;
            }
            SpringKind::Bilinear => p.f2 = p.f1,
            SpringKind::Trilinear => {}
        }
        self.validate(&p)?;
        Ok(p)
    }

    /// Check the values this model uses.
    pub fn validate(&self, p: &Params) -> Result<(), ParamError> {
        let bad = |name: ParamName, requirement: &'static str| ParamError::Invalid {
            name: name.as_str(),
            value: p.get(name),
            requirement,
        };
        for name in self.param_names() {
            if !p.get(name).is_finite() {
                return Err(bad(name, "must be a finite number"));
            }
        }
        if p.u0 == 0.0 {
            return Err(bad(
                ParamName::U0,
                "must be nonzero: the release displacement (a test released from 0 does not move)",
            ));
        }
        if p.f0 <= 0.0 {
            return Err(bad(ParamName::F0, "must be > 0"));
        }
        if self.uses(ParamName::Uy) {
            if p.uy <= 0.0 {
                return Err(bad(ParamName::Uy, "must be > 0"));
            }
            if p.f1 <= 0.0 {
                return Err(bad(ParamName::F1, "must be > 0"));
            }
            if p.f1 >= p.f0 {
                return Err(bad(ParamName::F1, "must be < f0 (k0 > k1)"));
            }
        }
        if self.uses(ParamName::F2) {
            if p.f2 <= 0.0 {
                return Err(bad(ParamName::F2, "must be > 0"));
            }
            if p.f2 >= p.f0 {
                return Err(bad(ParamName::F2, "must be < f0 (k0 > k2)"));
            }
            if p.u3 <= p.uy {
                return Err(bad(ParamName::U3, "must be > uy"));
            }
        }
        if self.uses(ParamName::UF0) && p.uf0 < 0.0 {
            return Err(bad(ParamName::UF0, "must be >= 0"));
        }
        if self.uses(ParamName::Zeta0) && p.zeta0 < 0.0 {
            return Err(bad(ParamName::Zeta0, "must be >= 0"));
        }
        Ok(())
    }
}

impl FromStr for ModelSpec {
    type Err = SpecError;

    fn from_str(s: &str) -> Result<Self, SpecError> {
        let (mut spring, mut friction, mut damper) = (None, None, None);
        for part in s.split('+').map(str::trim) {
            let dup = |kind: &str| SpecError::Duplicate {
                spec: s.to_string(),
                kind: kind.to_string(),
            };
            match part {
                "linear" | "bilinear" | "trilinear" => {
                    let k = match part {
                        "linear" => SpringKind::Linear,
                        "bilinear" => SpringKind::Bilinear,
                        _ => SpringKind::Trilinear,
                    };
                    if spring.replace(k).is_some() {
                        return Err(dup("a spring"));
                    }
                }
                "coulomb" | "lcfm" => {
                    let k = if part == "coulomb" {
                        FrictionKind::Coulomb
                    } else {
                        FrictionKind::Lcfm
                    };
                    if friction.replace(k).is_some() {
                        return Err(dup("a friction law"));
                    }
                }
                "viscous" => {
                    if damper.replace(DamperKind::Viscous).is_some() {
                        return Err(dup("a damper"));
                    }
                }
                // "none" may stand for a missing friction or damper.
                "none" => {}
                other => {
                    return Err(SpecError::Unknown {
                        name: other.to_string(),
                        known: "linear, bilinear, trilinear, coulomb, lcfm, viscous".into(),
                    })
                }
            }
        }
        Ok(ModelSpec {
            spring: spring.ok_or_else(|| SpecError::NoSpring(s.to_string()))?,
            friction: friction.unwrap_or(FrictionKind::None),
            damper: damper.unwrap_or(DamperKind::None),
        })
    }
}

impl fmt::Display for ModelSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self.spring {
            SpringKind::Linear => "linear",
            SpringKind::Bilinear => "bilinear",
            SpringKind::Trilinear => "trilinear",
        })?;
        match self.friction {
            FrictionKind::None => {}
            FrictionKind::Coulomb => f.write_str("+coulomb")?,
            FrictionKind::Lcfm => f.write_str("+lcfm")?,
        }
        if self.damper == DamperKind::Viscous {
            f.write_str("+viscous")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_round_trip() {
        for s in [
            "linear",
            "bilinear+coulomb",
            "trilinear+lcfm+viscous",
            "bilinear+viscous",
        ] {
            assert_eq!(s.parse::<ModelSpec>().unwrap().to_string(), s);
        }
        assert_eq!(
            "viscous+trilinear+none"
                .parse::<ModelSpec>()
                .unwrap()
                .to_string(),
            "trilinear+viscous"
        );
        assert!(matches!(
            "bilinear+trilinear".parse::<ModelSpec>(),
            Err(SpecError::Duplicate { .. })
        ));
        assert!(matches!(
            "coulomb".parse::<ModelSpec>(),
            Err(SpecError::NoSpring(_))
        ));
        assert!(matches!(
            "trilinear+magic".parse::<ModelSpec>(),
            Err(SpecError::Unknown { .. })
        ));
    }

    #[test]
    fn validation_names_the_field() {
        let m = ModelSpec::FULL;
        let mut p = Params::table_8_1(5).unwrap();
        assert!(m.validate(&p).is_ok());
        p.u3 = 0.005;
        let e = m.validate(&p).unwrap_err().to_string();
        assert!(e.contains("u3") && e.contains("> uy"), "{e}");
        p = Params::table_8_1(5).unwrap();
        p.f2 = 0.6;
        assert!(m.validate(&p).unwrap_err().to_string().contains("k0 > k2"));
        p.f2 = f64::NAN;
        assert!(m.validate(&p).unwrap_err().to_string().contains("finite"));
    }

    #[test]
    fn maps_need_exactly_the_model_parameters() {
        let m: ModelSpec = "bilinear+coulomb".parse().unwrap();
        let full = Params::table_8_1(5).unwrap();
        let mut map: BTreeMap<_, _> = m
            .param_names()
            .into_iter()
            .map(|p| (p, full.get(p)))
            .collect();
        let p = m.params_from_map(&map).unwrap();
        assert_eq!(p.f2, p.f1);
        assert_eq!(p.rf0, 0.0);
        map.insert(ParamName::F2, 0.3);
        assert!(matches!(
            m.params_from_map(&map),
            Err(ParamError::Unused { name: "f2", .. })
        ));
        map.remove(&ParamName::F2);
        map.remove(&ParamName::UF0);
        assert!(matches!(
            m.params_from_map(&map),
            Err(ParamError::Missing { name: "uF0", .. })
        ));
    }
}
