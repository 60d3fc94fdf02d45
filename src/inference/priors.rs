//! Priors on the identification parameters.
//!
//! By default each parameter is uniform within documented physical bounds
//! ([`default_bounds`]). A prior file (JSON, or TOML when its name ends in
//! `.toml`) overrides any of them:
//!
//! ```json
//! { "f0":    { "dist": "normal",    "mean": 0.55, "sd": 0.05 },
//!   "zeta0": { "dist": "lognormal", "mu": -3.5,   "sigma": 0.5 },
//!   "rF0":   { "dist": "uniform",   "lower": -0.05, "upper": 0.05 } }
//! ```
//!
//! Normal and log-normal priors are truncated to the parameter's physical
//! bounds unless `lower`/`upper` are given. Structural constraints
//! (`k0 > k1`, `k0 > k2`, `u3 > uy`) are zero prior mass: the posterior is
//! `-inf` there (the model refuses such parameters).
//!
//! # Formula
//! ```text
//! uniform:   ln p = -ln(upper - lower)
//! normal:    ln p = -((x - mean)/sd)^2 / 2 - ln(sd sqrt(2 pi))
//! lognormal: ln p = -((ln x - mu)/sigma)^2 / 2 - ln(x sigma sqrt(2 pi))
//! ```
//! (up to the truncation constant, which does not depend on `x`).
//!
//! ```
//! use hbis::inference::Prior;
//!
//! let p = Prior::Uniform { lower: 0.0, upper: 4.0 };
//! assert!((p.ln_pdf(1.0) + 4f64.ln()).abs() < 1e-15);
//! assert_eq!(p.ln_pdf(5.0), f64::NEG_INFINITY);
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a prior could not be built or read.
#[derive(Debug, Error)]
pub enum PriorError {
    /// The prior file could not be read.
    #[error("cannot read prior file {path}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The file is not valid JSON or TOML.
    #[error("prior file is not valid {format}: {message}")]
    Syntax {
        format: &'static str,
        message: String,
    },
    /// The file names a parameter the model does not have.
    #[error("prior for `{name}`: the model has no such parameter (it has: {known})")]
    Unknown { name: String, known: String },
    /// A prior's entry is malformed.
    #[error("prior for `{name}`: {message}")]
    Entry { name: String, message: String },
    /// A prior's values are out of range.
    #[error("prior for `{name}`: {reason}")]
    Invalid { name: String, reason: String },
    /// A parameter has no physical default bounds and no prior was given.
    #[error("no default prior for `{name}`; give one in the prior file")]
    NoDefault { name: String },
}

/// The prior of one parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "dist", rename_all = "lowercase", deny_unknown_fields)]
pub enum Prior {
    /// Uniform on `[lower, upper]`.
    Uniform { lower: f64, upper: f64 },
    /// Normal, truncated to `[lower, upper]`.
    Normal {
        mean: f64,
        sd: f64,
        #[serde(default = "neg_inf")]
        lower: f64,
        #[serde(default = "pos_inf")]
        upper: f64,
    },
    /// Log-normal (`ln x ~ N(mu, sigma)`), truncated to `[lower, upper]`.
    #[serde(rename = "lognormal")]
    LogNormal {
        mu: f64,
        sigma: f64,
        #[serde(default = "neg_inf")]
        lower: f64,
        #[serde(default = "pos_inf")]
        upper: f64,
    },
}

fn neg_inf() -> f64 {
    f64::NEG_INFINITY
}

fn pos_inf() -> f64 {
    f64::INFINITY
}

/// Physical bounds used by the default uniform priors and to truncate
/// normal and log-normal ones. Wide enough for any isolation system tested
/// by release (isolated periods 0.5-10 s, friction up to a few percent of
/// the released force); `rho` is the AR(1) noise correlation.
///
/// | name | lower | upper | unit |
/// |---|---|---|---|
/// | `u0` | 0.005 | 0.5 | m |
/// | `uy` | 0.0005 | 0.05 | m |
/// | `uF0` | 0 | 0.02 | m |
/// | `rF0` | -0.1 | 0.1 | - |
/// | `zeta0` | 0 | 0.2 | - |
/// | `f0` | 0.1 | 2 | Hz |
/// | `f1` | 0.05 | 2 | Hz |
/// | `f2` | 0.02 | 2 | Hz |
/// | `u3` | 0.001 | 0.5 | m |
/// | `rho` | -0.999 | 0.999 | - |
pub fn default_bounds(name: &str) -> Option<(f64, f64)> {
    match name {
        "rho" => Some(RHO_BOUNDS),
        _ => crate::model::ParamName::parse(name).map(|p| p.bounds()),
    }
}

/// Default bounds of the AR(1) coefficient `rho`.
pub const RHO_BOUNDS: (f64, f64) = (-0.999, 0.999);

impl Prior {
    /// Log-density up to a constant; `-inf` outside the support.
    pub fn ln_pdf(&self, x: f64) -> f64 {
        let (lo, hi) = self.support();
        if !(x >= lo && x <= hi) {
            return f64::NEG_INFINITY;
        }
        let ln_sqrt_2pi = 0.5 * (2.0 * std::f64::consts::PI).ln();
        match *self {
            Prior::Uniform { lower, upper } => -(upper - lower).ln(),
            Prior::Normal { mean, sd, .. } => {
                let z = (x - mean) / sd;
                -0.5 * z * z - sd.ln() - ln_sqrt_2pi
            }
            Prior::LogNormal { mu, sigma, .. } => {
                if x <= 0.0 {
                    return f64::NEG_INFINITY;
                }
                let z = (x.ln() - mu) / sigma;
                -0.5 * z * z - (x * sigma).ln() - ln_sqrt_2pi
            }
        }
    }

    /// The support `[lower, upper]` (may be infinite for untruncated priors).
    pub fn support(&self) -> (f64, f64) {
        match *self {
            Prior::Uniform { lower, upper } => (lower, upper),
            Prior::Normal { lower, upper, .. } => (lower, upper),
            Prior::LogNormal { lower, upper, .. } => (lower.max(0.0), upper),
        }
    }

    /// Standard deviation of the untruncated distribution (used to judge
    /// how much the data contract it).
    pub fn sd(&self) -> f64 {
        match *self {
            Prior::Uniform { lower, upper } => (upper - lower) / 12f64.sqrt(),
            Prior::Normal { sd, .. } => sd,
            Prior::LogNormal { mu, sigma, .. } => {
                let s2 = sigma * sigma;
                ((s2.exp() - 1.0) * (2.0 * mu + s2).exp()).sqrt()
            }
        }
    }

    /// Checks the values and truncates an open support to `bounds`.
    fn checked(self, name: &str, bounds: Option<(f64, f64)>) -> Result<Self, PriorError> {
        let invalid = |reason: String| PriorError::Invalid {
            name: name.to_string(),
            reason,
        };
        let clip = |lower: f64, upper: f64| -> Result<(f64, f64), PriorError> {
            let (lo, hi) = match bounds {
                Some((bl, bu)) => (
                    if lower.is_finite() { lower } else { bl },
                    if upper.is_finite() { upper } else { bu },
                ),
                None => (lower, upper),
            };
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(invalid(format!(
                    "need finite lower < upper, got [{lo}, {hi}]"
                )));
            }
            Ok((lo, hi))
        };
        let p = match self {
            Prior::Uniform { lower, upper } => {
                if !(lower.is_finite() && upper.is_finite() && lower < upper) {
                    return Err(invalid(format!(
                        "uniform needs finite lower < upper, got [{lower}, {upper}]"
                    )));
                }
                self
            }
            Prior::Normal {
                mean,
                sd,
                lower,
                upper,
            } => {
                if !(mean.is_finite() && sd.is_finite() && sd > 0.0) {
                    return Err(invalid(format!(
                        "normal needs finite mean and sd > 0, got mean {mean}, sd {sd}"
                    )));
                }
                let (lower, upper) = clip(lower, upper)?;
                Prior::Normal {
                    mean,
                    sd,
                    lower,
                    upper,
                }
            }
            Prior::LogNormal {
                mu,
                sigma,
                lower,
                upper,
            } => {
                if !(mu.is_finite() && sigma.is_finite() && sigma > 0.0) {
                    return Err(invalid(format!(
                        "lognormal needs finite mu and sigma > 0, got mu {mu}, sigma {sigma}"
                    )));
                }
                let (lower, upper) = clip(lower.max(0.0), upper)?;
                Prior::LogNormal {
                    mu,
                    sigma,
                    lower,
                    upper,
                }
            }
        };
        Ok(p)
    }
}

/// Independent priors, one per parameter, in a fixed order.
#[derive(Debug, Clone)]
pub struct Priors {
    names: Vec<String>,
    priors: Vec<Prior>,
}

impl Priors {
    /// Uniform priors within [`default_bounds`] for each name.
    pub fn defaults(names: &[String]) -> Result<Self, PriorError> {
        let priors = names
            .iter()
            .map(|n| {
                default_bounds(n)
                    .map(|(lower, upper)| Prior::Uniform { lower, upper })
                    .ok_or_else(|| PriorError::NoDefault { name: n.clone() })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            names: names.to_vec(),
            priors,
        })
    }

    /// Uniform priors on `bounds`, one per name.
    pub fn uniform(names: Vec<String>, bounds: &[(f64, f64)]) -> Option<Self> {
        let priors = bounds
            .iter()
            .map(|&(lower, upper)| Prior::Uniform { lower, upper })
            .collect();
        Self::from_parts(names, priors)
    }

    /// These priors with some replaced by `overrides` (name -> prior); each
    /// override is checked, and a bound it leaves open is taken from the
    /// support of the prior it replaces.
    pub fn with_overrides(self, overrides: &BTreeMap<String, Prior>) -> Result<Self, PriorError> {
        for name in overrides.keys() {
            if !self.names.contains(name) {
                return Err(PriorError::Unknown {
                    name: name.clone(),
                    known: self.names.join(", "),
                });
            }
        }
        let mut priors = Vec::with_capacity(self.names.len());
        for (n, base) in self.names.iter().zip(self.priors) {
            let p = match overrides.get(n) {
                Some(p) => p.checked(n, Some(base.support()))?,
                None => base,
            };
            priors.push(p);
        }
        Ok(Self {
            names: self.names,
            priors,
        })
    }

    /// These priors overridden by the entries of a JSON or TOML text.
    pub fn parse(self, text: &str, toml: bool) -> Result<Self, PriorError> {
        let raw: BTreeMap<String, serde_json::Value> = if toml {
            let table: toml::Table = toml::from_str(text).map_err(|e| PriorError::Syntax {
                format: "TOML",
                message: e.to_string().trim().replace('\n', " "),
            })?;
            let value = serde_json::to_value(table).map_err(|e| PriorError::Syntax {
                format: "TOML",
                message: e.to_string(),
            })?;
            serde_json::from_value(value).map_err(|e| PriorError::Syntax {
                format: "TOML",
                message: e.to_string(),
            })?
        } else {
            crate::data::strict_json::parse(text)
                .and_then(serde_json::from_value)
                .map_err(|e| PriorError::Syntax {
                    format: "JSON",
                    message: e.to_string(),
                })?
        };
        let mut overrides = BTreeMap::new();
        for (name, value) in raw {
            let prior: Prior = serde_json::from_value(value).map_err(|e| PriorError::Entry {
                name: name.clone(),
                message: e.to_string(),
            })?;
            overrides.insert(name, prior);
        }
        self.with_overrides(&overrides)
    }

    /// These priors overridden by a prior file (TOML if the name ends in
    /// `.toml`, else JSON).
    pub fn read(self, path: &Path) -> Result<Self, PriorError> {
        let text = std::fs::read_to_string(path).map_err(|source| PriorError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        self.parse(&text, toml)
    }

    /// Priors from names and priors of equal length.
    pub fn from_parts(names: Vec<String>, priors: Vec<Prior>) -> Option<Self> {
        (names.len() == priors.len()).then_some(Self { names, priors })
    }

    /// The first `n` priors (a model's, before its noise model's).
    pub fn head(&self, n: usize) -> Self {
        let n = n.min(self.names.len());
        Self {
            names: self.names[..n].to_vec(),
            priors: self.priors[..n].to_vec(),
        }
    }

    /// Parameter names in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The priors in order.
    pub fn priors(&self) -> &[Prior] {
        &self.priors
    }

    /// Sum of log-densities; `-inf` outside the support.
    pub fn ln_pdf(&self, theta: &[f64]) -> f64 {
        let mut s = 0.0;
        for (p, &x) in self.priors.iter().zip(theta) {
            s += p.ln_pdf(x);
            if s == f64::NEG_INFINITY {
                break;
            }
        }
        s
    }

    /// Lower and upper ends of each support.
    pub fn box_bounds(&self) -> (Vec<f64>, Vec<f64>) {
        self.priors.iter().map(|p| p.support()).unzip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        ["u0", "f0", "zeta0"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    }

    #[test]
    fn normal_and_lognormal_log_densities() {
        let n = Prior::Normal {
            mean: 1.0,
            sd: 2.0,
            lower: -10.0,
            upper: 10.0,
        };
        let expected = -0.5 * 0.25 - (2.0 * (2.0 * std::f64::consts::PI).sqrt()).ln();
        assert!((n.ln_pdf(2.0) - expected).abs() < 1e-14);
        let l = Prior::LogNormal {
            mu: 0.0,
            sigma: 1.0,
            lower: 0.0,
            upper: 10.0,
        };
        let expected = -(2.0 * std::f64::consts::PI).sqrt().ln();
        assert!((l.ln_pdf(1.0) - expected).abs() < 1e-14);
        assert_eq!(l.ln_pdf(11.0), f64::NEG_INFINITY);
    }

    #[test]
    fn json_and_toml_files_override_defaults_and_truncate() {
        let json = r#"{"f0": {"dist": "normal", "mean": 0.55, "sd": 0.05}}"#;
        let p = Priors::defaults(&names())
            .unwrap()
            .parse(json, false)
            .unwrap();
        assert_eq!(
            p.priors()[1],
            Prior::Normal {
                mean: 0.55,
                sd: 0.05,
                lower: 0.1,
                upper: 2.0
            }
        );
        assert_eq!(
            p.priors()[0],
            Prior::Uniform {
                lower: 0.005,
                upper: 0.5
            }
        );
        let toml = "[zeta0]\ndist = \"lognormal\"\nmu = -3.5\nsigma = 0.5\n";
        let q = Priors::defaults(&names())
            .unwrap()
            .parse(toml, true)
            .unwrap();
        assert!(matches!(q.priors()[2], Prior::LogNormal { upper, .. } if upper == 0.2));
    }

    #[test]
    fn bad_entries_name_the_parameter() {
        let err = |text: &str| {
            Priors::defaults(&names())
                .unwrap()
                .parse(text, false)
                .unwrap_err()
                .to_string()
        };
        assert!(err(r#"{"f9": {"dist": "uniform", "lower": 0, "upper": 1}}"#).contains("`f9`"));
        assert!(err(r#"{"f0": {"dist": "normal", "mean": 0.5, "sd": -1}}"#)
            .contains("prior for `f0`: normal needs"));
        assert!(err(r#"{"f0": {"dist": "cauchy"}}"#).contains("prior for `f0`"));
        assert!(err(r#"{"u0": {"dist": "uniform", "lower": 2, "upper": 1}}"#).contains("`u0`"));
        assert!(err("{").contains("not valid JSON"));
        // Issue 37: the second `f0` was kept without a word.
        let twice = r#"{"f0": {"dist": "uniform", "lower": 0.2, "upper": 1},
                        "f0": {"dist": "uniform", "lower": 0.3, "upper": 1}}"#;
        let e = err(twice);
        assert!(e.contains("duplicate key `f0` at line 2"), "{e}");
    }
}
