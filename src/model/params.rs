//! The identification parameters of the paper's Table 8.1, per unit mass.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::error::ParamError;
use super::layout::ParamSpec;

/// Name of one identification parameter, spelled as in the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ParamName {
    /// `u0` (m): displacement at release.
    #[serde(rename = "u0")]
    U0,
    /// `uy` (m): first yield displacement, `uy = F2/(k0 - k1)`.
    #[serde(rename = "uy")]
    Uy,
    /// `uF0` (m): friction displacement, `F_F0 = uF0 k0`.
    #[serde(rename = "uF0")]
    UF0,
    /// `rF0` (-): friction slope ratio, `k_F = rF0 k0`.
    #[serde(rename = "rF0")]
    RF0,
    /// `zeta0` (-): damping ratio, `c = 2 zeta0 w0 m`.
    #[serde(rename = "zeta0")]
    Zeta0,
    /// `f0` (Hz): elastic frequency, `k0 = m (2 pi f0)^2`.
    #[serde(rename = "f0")]
    F0,
    /// `f1` (Hz): first post-yield frequency, `k1 = m (2 pi f1)^2`.
    #[serde(rename = "f1")]
    F1,
    /// `f2` (Hz): second post-yield frequency, `k2 = m (2 pi f2)^2`.
    #[serde(rename = "f2")]
    F2,
    /// `u3` (m): second yield displacement.
    #[serde(rename = "u3")]
    U3,
}

impl ParamName {
    /// All names in the paper's order.
    pub const ALL: [ParamName; 9] = [
        ParamName::U0,
        ParamName::Uy,
        ParamName::UF0,
        ParamName::RF0,
        ParamName::Zeta0,
        ParamName::F0,
        ParamName::F1,
        ParamName::F2,
        ParamName::U3,
    ];

    /// The paper's symbol, e.g. `"uF0"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ParamName::U0 => "u0",
            ParamName::Uy => "uy",
            ParamName::UF0 => "uF0",
            ParamName::RF0 => "rF0",
            ParamName::Zeta0 => "zeta0",
            ParamName::F0 => "f0",
            ParamName::F1 => "f1",
            ParamName::F2 => "f2",
            ParamName::U3 => "u3",
        }
    }

    /// SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            ParamName::U0 | ParamName::Uy | ParamName::UF0 | ParamName::U3 => "m",
            ParamName::RF0 | ParamName::Zeta0 => "-",
            ParamName::F0 | ParamName::F1 | ParamName::F2 => "Hz",
        }
    }

    /// One-line physical meaning.
    pub fn meaning(self) -> &'static str {
        match self {
            ParamName::U0 => "displacement at release",
            ParamName::Uy => "first yield displacement of the rubber bearings",
            ParamName::UF0 => "friction displacement, F_F0 = uF0 k0",
            ParamName::RF0 => "friction slope ratio, k_F = rF0 k0",
            ParamName::Zeta0 => "viscous damping ratio, c = 2 zeta0 w0 m",
            ParamName::F0 => "elastic frequency, k0 = m (2 pi f0)^2",
            ParamName::F1 => "first post-yield frequency, k1 = m (2 pi f1)^2",
            ParamName::F2 => "second post-yield frequency, k2 = m (2 pi f2)^2",
            ParamName::U3 => "second yield displacement",
        }
    }

    /// Default prior bounds (uniform), in SI units: wide enough for the
    /// isolation systems of the paper and beyond.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            ParamName::U0 => (0.005, 0.5),
            ParamName::Uy => (0.0005, 0.05),
            ParamName::UF0 => (0.0, 0.02),
            ParamName::RF0 => (-0.1, 0.1),
            ParamName::Zeta0 => (0.0, 0.2),
            ParamName::F0 => (0.1, 2.0),
            ParamName::F1 => (0.05, 2.0),
            ParamName::F2 => (0.02, 2.0),
            ParamName::U3 => (0.001, 0.5),
        }
    }

    /// A physically meaningful change, in the parameter's unit: a
    /// millimetre of displacement, a hundredth of a damping ratio, 0.01
    /// Hz, and 0.005 of the friction slope `rF0`: over a release of
    /// 0.1 m that changes the friction force by 0.5 mm of `k0`, a quarter
    /// of the paper's `uF0` (the paper's own Test 6 slope, -0.0071, is a
    /// detectable effect; docs/criticism.md, "Row 6 and the scale of
    /// `rF0`").
    pub fn scale(self) -> f64 {
        match self {
            ParamName::U0 | ParamName::Uy | ParamName::UF0 | ParamName::U3 => 1e-3,
            ParamName::RF0 => 0.005,
            ParamName::Zeta0 => 0.01,
            ParamName::F0 | ParamName::F1 | ParamName::F2 => 0.01,
        }
    }

    /// The declaration of the parameter (name, unit, bounds, meaning,
    /// scale); its neutral value is the one that switches its component off
    /// where there is one (`uF0`, `rF0`, `zeta0`: 0).
    pub fn spec(self) -> ParamSpec {
        let neutral = match self {
            ParamName::UF0 | ParamName::RF0 | ParamName::Zeta0 => 0.0,
            _ => 0.5 * (self.bounds().0 + self.bounds().1),
        };
        ParamSpec::new(self.as_str(), self.unit(), self.bounds(), neutral)
            .meaning(self.meaning())
            .scale(self.scale())
            .shows(self.shows())
    }

    /// How a record shows the parameter: the feature of the acceleration
    /// it changes.
    pub fn shows(self) -> &'static str {
        match self {
            ParamName::U0 => "it sets the release displacement and so the amplitude of the whole record",
            ParamName::Uy => "it sets where the rubber bearings yield: the elastic branch after each reversal is 2 uy wide",
            ParamName::UF0 => "it sets the constant part of the friction force, F_F0 = uF0 k0, seen as the acceleration jump at every reversal",
            ParamName::RF0 => "it makes the friction force grow with the displacement, F_F = (uF0 + rF0 |u|) k0; it changes the jump at a reversal in proportion to the amplitude there, so the record shows it only through how the jumps change from cycle to cycle",
            ParamName::Zeta0 => "it sets the viscous force c u', largest mid-swing at peak velocity, and with friction the decay of the amplitude",
            ParamName::F0 => "it sets the elastic stiffness: the slope of the acceleration right after each reversal",
            ParamName::F1 => "it sets the first post-yield stiffness, which governs the period of the large swings",
            ParamName::F2 => "it sets the stiffness beyond u3, active only while the swing passes u3",
            ParamName::U3 => "it sets where the third branch starts; it is seen only if the swing passes it",
        }
    }

    /// Parse a paper symbol.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.as_str() == s)
    }
}

impl fmt::Display for ParamName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A full set of identification parameters. Parameters a model does not use
/// hold the value that makes their component vanish (`rF0 = 0`, `zeta0 = 0`,
/// `uF0 = 0`, `f2 = f1`, `u3 = inf`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// `u0` (m): displacement at release.
    pub u0: f64,
    /// `uy` (m): first yield displacement.
    pub uy: f64,
    /// `uF0` (m): friction displacement, `F_F0 = uF0 k0`.
    pub uf0: f64,
    /// `rF0` (-): friction slope ratio, `k_F = rF0 k0`.
    pub rf0: f64,
    /// `zeta0` (-): damping ratio, `c = 2 zeta0 w0 m`.
    pub zeta0: f64,
    /// `f0` (Hz): elastic frequency.
    pub f0: f64,
    /// `f1` (Hz): first post-yield frequency.
    pub f1: f64,
    /// `f2` (Hz): second post-yield frequency.
    pub f2: f64,
    /// `u3` (m): second yield displacement.
    pub u3: f64,
}

impl Params {
    /// The Table 8.1 column of Test `n` (3, 5, 6, 7 or 8) of the Solarino
    /// building.
    ///
    /// ```
    /// let p = hbis::model::Params::table_8_1(5).unwrap();
    /// assert_eq!(p.u0, 0.1166);
    /// ```
    pub fn table_8_1(test: u32) -> Option<Self> {
        let col = match test {
            3 => [
                0.10753, 0.00898, 0.00179, -0.00119, 0.02962, 0.56318, 0.43089, 0.26401, 0.06951,
            ],
            5 => [
                0.11660, 0.01167, 0.00234, 0.00235, 0.02256, 0.53979, 0.41723, 0.37477, 0.08252,
            ],
            6 => [
                0.11391, 0.01069, 0.00217, -0.00706, 0.02149, 0.56118, 0.42171, 0.30483, 0.07611,
            ],
            7 => [
                0.08500, 0.00848, 0.00218, -0.01466, 0.03583, 0.55743, 0.44264, 0.32331, 0.05358,
            ],
            8 => [
                0.08999, 0.00732, 0.00245, -0.02912, 0.04461, 0.55218, 0.44805, 0.29516, 0.05696,
            ],
            _ => return None,
        };
        Some(Self::from_array(col))
    }

    /// From values in the order of [`ParamName::ALL`].
    pub fn from_array(a: [f64; 9]) -> Self {
        Self {
            u0: a[0],
            uy: a[1],
            uf0: a[2],
            rf0: a[3],
            zeta0: a[4],
            f0: a[5],
            f1: a[6],
            f2: a[7],
            u3: a[8],
        }
    }

    /// Values of the parameters `spec` uses, in its order (the inverse of
    /// [`crate::model::ModelSpec::params_from_slice`]).
    pub fn to_theta(&self, spec: &crate::model::ModelSpec) -> Vec<f64> {
        spec.param_names()
            .into_iter()
            .map(|p| self.get(p))
            .collect()
    }

    /// Value of one parameter.
    pub fn get(&self, p: ParamName) -> f64 {
        match p {
            ParamName::U0 => self.u0,
            ParamName::Uy => self.uy,
            ParamName::UF0 => self.uf0,
            ParamName::RF0 => self.rf0,
            ParamName::Zeta0 => self.zeta0,
            ParamName::F0 => self.f0,
            ParamName::F1 => self.f1,
            ParamName::F2 => self.f2,
            ParamName::U3 => self.u3,
        }
    }

    /// Set one parameter.
    pub fn set(&mut self, p: ParamName, v: f64) {
        match p {
            ParamName::U0 => self.u0 = v,
            ParamName::Uy => self.uy = v,
            ParamName::UF0 => self.uf0 = v,
            ParamName::RF0 => self.rf0 = v,
            ParamName::Zeta0 => self.zeta0 = v,
            ParamName::F0 => self.f0 = v,
            ParamName::F1 => self.f1 = v,
            ParamName::F2 => self.f2 = v,
            ParamName::U3 => self.u3 = v,
        }
    }

    /// Parse a JSON object `{"u0": 0.1, ...}` (or `{"params": {...}}`); names are checked against
    /// the paper's set (the model checks which it needs).
    pub fn map_from_json(text: &str) -> Result<BTreeMap<ParamName, f64>, ParamError> {
        let value =
            crate::data::strict_json::parse(text).map_err(|e| ParamError::Json(e.to_string()))?;
        let obj = match value {
            // Accept a bare object or one holding it under "params"
            // (the shape of hbis' own outputs and of the shared records).
            serde_json::Value::Object(mut o) => match o.remove("params") {
                Some(serde_json::Value::Object(inner)) => inner,
                Some(_) => return Err(ParamError::Json("\"params\" must be an object".into())),
                None => o,
            },
            _ => {
                return Err(ParamError::Json(
                    "expected a JSON object of name: value".into(),
                ))
            }
        };
        let mut out = BTreeMap::new();
        for (k, v) in obj {
            let name = ParamName::parse(&k).ok_or_else(|| ParamError::Unknown(k.clone()))?;
            let x = v.as_f64().ok_or_else(|| ParamError::NotANumber {
                name: k.clone(),
                found: v.to_string(),
            })?;
            out.insert(name, x);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 37: the second `u0` was kept without a word.
    #[test]
    fn a_parameter_named_twice_is_refused() {
        let e = Params::map_from_json(r#"{"u0": 0.1, "u0": 0.2}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("duplicate key `u0`"), "{e}");
    }
}
