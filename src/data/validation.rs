//! Sanity checks of a record before a fit: things that parse and align but
//! are probably wrong, reported as warnings (the fit still runs).
//!
//! Each [`Warning`] has a stable kebab-case `code`:
//!
//! | code | when |
//! | --- | --- |
//! | `sampling-interval` | the step is above 0.05 s or below 1e-5 s |
//! | `acceleration-units` | the peak \|a\| after the release is outside 0.05-50 m/s^2 |
//! | `outliers` | single-sample outliers ([`Record::outliers`]) |
//! | `dc-offset` | the samples before the release average far from zero |
//! | `no-release` | the peak \|a\| is under 8 times the noise level |
//! | `short-record` | the record ends while the motion is still large (its last 5 % reach half the peak \|a\|) |
//!
//! A record constant from the release on is not a warning but an error of
//! [`Record::aligned`] ([`crate::data::RecordError::Constant`]): nothing
//! could be fitted to it.
//!
//! ```
//! use hbis::data::{record_warnings, AccelUnits, Record};
//!
//! // A release recorded in g (0.03 g is 0.29 m/s^2), decaying to rest.
//! let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.005).collect();
//! let a: Vec<f64> = t.iter().map(|t| -0.03 * (-1.5 * t).exp() * (3.5 * t).cos()).collect();
//! let rec = Record::new(t, a).unwrap();
//! let warnings = record_warnings(&rec, &rec.aligned(None).unwrap());
//! assert_eq!(warnings[0].code, "acceleration-units");
//! let units: AccelUnits = "g".parse().unwrap();
//! let rec = rec.in_units(units).unwrap();
//! assert!(record_warnings(&rec, &rec.aligned(None).unwrap()).is_empty());
//! ```

use std::fmt;
use std::str::FromStr;

use thiserror::Error;

use super::record::{Aligned, Record};

/// Something about a record that is probably wrong.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Warning {
    /// Stable kebab-case identifier (see the module documentation).
    pub code: String,
    /// What was found, with the numbers.
    pub message: String,
}

impl Warning {
    fn new(code: &str, message: String) -> Self {
        Self {
            code: code.to_string(),
            message,
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "warning [{}]: {}", self.code, self.message)
    }
}

/// Unit of the acceleration column of a record file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum AccelUnits {
    /// m/s^2, what hbis works in (`"m/s2"`).
    #[default]
    MetresPerSecondSquared,
    /// Standard gravity, 9.80665 m/s^2 (`"g"`).
    G,
    /// mm/s^2 (`"mm/s2"`).
    MillimetresPerSecondSquared,
}

impl AccelUnits {
    /// Every unit.
    pub const ALL: [AccelUnits; 3] = [
        AccelUnits::MetresPerSecondSquared,
        AccelUnits::G,
        AccelUnits::MillimetresPerSecondSquared,
    ];

    /// `"m/s2"`, `"g"` or `"mm/s2"`: what [`FromStr`] reads.
    pub fn as_str(self) -> &'static str {
        match self {
            AccelUnits::MetresPerSecondSquared => "m/s2",
            AccelUnits::G => "g",
            AccelUnits::MillimetresPerSecondSquared => "mm/s2",
        }
    }

    /// Metres per second squared in one unit.
    pub fn factor(self) -> f64 {
        match self {
            AccelUnits::MetresPerSecondSquared => 1.0,
            AccelUnits::G => 9.80665,
            AccelUnits::MillimetresPerSecondSquared => 1e-3,
        }
    }
}

impl fmt::Display for AccelUnits {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An acceleration unit hbis does not know.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("unknown acceleration unit `{0}`: expected m/s2, g or mm/s2")]
pub struct UnknownUnits(pub String);

impl FromStr for AccelUnits {
    type Err = UnknownUnits;

    /// `m/s2` (or `m/s^2`), `g`, `mm/s2` (or `mm/s^2`), any case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().replace('^', "").as_str() {
            "m/s2" => Ok(AccelUnits::MetresPerSecondSquared),
            "g" => Ok(AccelUnits::G),
            "mm/s2" => Ok(AccelUnits::MillimetresPerSecondSquared),
            _ => Err(UnknownUnits(s.to_string())),
        }
    }
}

/// Plausible sampling step of a release test (s): a coarser one cannot
/// follow the friction reversals of a 1-3 s isolation period, a finer one
/// is not what a logger writes for a test of tens of seconds.
pub const DT_RANGE: (f64, f64) = (1e-5, 0.05);

/// Plausible peak |a| after the release (m/s^2). A release from 0.05-0.3 m
/// at 0.3-1 Hz starts at `(2 pi f)^2 u0`, about 0.2-12 m/s^2; the range
/// leaves a factor of about 4 above and a little room below, so that a
/// record in g of a typical test (peak about 0.1 g) is caught; a record in
/// g with a peak above 0.15 g cannot be told from one in m/s^2.
pub const PEAK_RANGE: (f64, f64) = (0.15, 50.0);

/// A release stands out when the peak |a| exceeds this many times the
/// noise level ([`Record::noise_level`]). The peak of `n` samples of pure
/// Gaussian noise is about `sqrt(2 ln n)` noise levels: under 6 for two
/// million samples.
pub const RELEASE_SNR: f64 = 8.0;

/// Fewest samples before the release from which an offset is judged.
pub const MIN_PRE_RELEASE: usize = 10;

/// A record is cut short when the peak |a| of its last [`END_SHARE`] of
/// samples (at least [`END_MIN`]) exceeds this share of its peak: a release
/// test ends at rest (the slider sticks, the acceleration vanishes), while a
/// record cut in its first swings ends near its peak.
pub const STILL_MOVING: f64 = 0.5;
/// The share of the record judged as its end.
pub const END_SHARE: f64 = 0.05;
/// Fewest samples judged as the end.
pub const END_MIN: usize = 5;

/// How a record ends while still moving.
struct End {
    window: usize,
    ratio: f64,
}

fn still_moving(a: &[f64]) -> Option<End> {
    let peak = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let window = ((a.len() as f64 * END_SHARE) as usize)
        .max(END_MIN)
        .min(a.len());
    let last = a[a.len() - window..]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let ratio = last / peak;
    (peak > 0.0 && ratio > STILL_MOVING).then_some(End { window, ratio })
}

/// `x` to 4 significant digits: plain from 0.001 to 10^5, else in
/// scientific notation (`0.01967`, `2.386`, `6.231e-5`).
fn num(x: f64) -> String {
    let m = x.abs();
    if m == 0.0 || !m.is_finite() {
        return format!("{x}");
    }
    if (1e-3..1e5).contains(&m) {
        let decimals = (3 - m.log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

/// Warnings for `record` aligned as `aligned` (in the order of the table
/// of the module documentation); empty for a plausible record.
pub fn record_warnings(record: &Record, aligned: &Aligned) -> Vec<Warning> {
    let mut out = Vec::new();
    let dt = aligned.dt;
    if dt > DT_RANGE.1 {
        out.push(Warning::new(
            "sampling-interval",
            format!(
                "the sampling step {} s ({} Hz) is too coarse for a release test (expected \
                 {} to {} s): it cannot follow the friction reversals of a 1-3 s isolation \
                 period; if the time column is in milliseconds, the step is {} ms ({} Hz)",
                num(dt),
                num(1.0 / dt),
                num(DT_RANGE.0),
                num(DT_RANGE.1),
                num(dt),
                num(1000.0 / dt)
            ),
        ));
    } else if dt < DT_RANGE.0 {
        out.push(Warning::new(
            "sampling-interval",
            format!(
                "the sampling step {} s ({} Hz) is implausibly fine for a release test \
                 (expected {} to {} s): is the time column in minutes or hours rather than \
                 seconds? (in minutes the step is {} s, in hours {} s)",
                num(dt),
                num(1.0 / dt),
                num(DT_RANGE.0),
                num(DT_RANGE.1),
                num(dt * 60.0),
                num(dt * 3600.0)
            ),
        ));
    }

    let outliers = record.outliers();
    let is_outlier = |i: usize| outliers.binary_search_by_key(&i, |o| o.index).is_ok();
    // `min`: an `aligned` of another record must not panic.
    let first = aligned.first_index.min(record.len());
    let peak = (first..record.len())
        .filter(|&i| !is_outlier(i))
        .fold(0.0f64, |m, i| m.max(record.a()[i].abs()));
    let noise = record.noise_level();

    let no_release = peak < RELEASE_SNR * noise;
    if no_release {
        out.push(Warning::new(
            "no-release",
            format!(
                "no release stands out of the noise: the peak |a| after the release, {} m/s^2, \
                 is {:.1} times the noise level {} m/s^2 (from second differences), under \
                 {RELEASE_SNR}; pure noise peaks at about 4-6 times",
                num(peak),
                peak / noise,
                num(noise)
            ),
        ));
    }

    if let Some(end) = still_moving(&aligned.a).filter(|_| !no_release) {
        out.push(Warning::new(
            "short-record",
            format!(
                "the record ends while the system still moves: its last {} samples reach {:.0} % \
                 of the peak |a| ({} samples, {} s after the release); a release test is recorded \
                 until the motion stops, and from part of it the parameters, even u0, are poorly \
                 determined; give the whole record",
                end.window,
                100.0 * end.ratio,
                aligned.a.len(),
                num(aligned.duration())
            ),
        ));
    }

    if !no_release && !(PEAK_RANGE.0..=PEAK_RANGE.1).contains(&peak) {
        let fits = AccelUnits::ALL.into_iter().find(|u| {
            *u != AccelUnits::MetresPerSecondSquared
                && (PEAK_RANGE.0..=PEAK_RANGE.1).contains(&(peak * u.factor()))
        });
        let side = if peak < PEAK_RANGE.0 {
            "below"
        } else {
            "above"
        };
        let hint = match fits {
            Some(u) => format!(
                "the record is probably in {u}: read that way its peak is {} m/s^2 \
                 (--accel-units {u})",
                num(peak * u.factor())
            ),
            None => format!(
                "no unit of {} brings it into range: check the record's scale",
                AccelUnits::ALL.map(AccelUnits::as_str).join(", ")
            ),
        };
        out.push(Warning::new(
            "acceleration-units",
            format!(
                "the peak |a| after the release, {} m/s^2, is {side} the {} to {} m/s^2 of a \
                 base-isolation release test (0.05-0.3 m at 0.3-1 Hz gives 0.2-12 m/s^2); {hint}",
                num(peak),
                num(PEAK_RANGE.0),
                num(PEAK_RANGE.1)
            ),
        ));
    }

    if !outliers.is_empty() {
        let rows: Vec<String> = outliers
            .iter()
            .take(10)
            .map(|o| o.row.to_string())
            .collect();
        let more = if outliers.len() > 10 { ", ..." } else { "" };
        let plural = if outliers.len() == 1 { "" } else { "s" };
        let worst = outliers
            .iter()
            .map(|o| (o.a - o.expected).abs())
            .fold(0.0f64, f64::max);
        out.push(Warning::new(
            "outliers",
            format!(
                "{} at row{plural} {}{more}, up to {} m/s^2 off the line of their neighbours \
                 (noise level {} m/s^2); release detection ignores them but a fit does not: \
                 drop them (--drop-outliers) to replace each by the mean of its neighbours",
                if outliers.len() == 1 {
                    "1 single-sample outlier (glitch)".to_string()
                } else {
                    format!("{} single-sample outliers (glitches)", outliers.len())
                },
                rows.join(", "),
                num(worst),
                num(noise)
            ),
        ));
    }

    let pre: Vec<f64> = (0..first)
        .filter(|&i| !is_outlier(i))
        .map(|i| record.a()[i])
        .collect();
    if pre.len() >= MIN_PRE_RELEASE {
        let n = pre.len() as f64;
        let mean = pre.iter().sum::<f64>() / n;
        let var = pre.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (var / n).sqrt();
        if mean.abs() > 3.0 * se && mean.abs() > 0.01 * peak {
            let rows = record.rows();
            out.push(Warning::new(
                "dc-offset",
                format!(
                    "the {} samples before the release (rows {}-{}) average {} m/s^2, {:.1} \
                     standard errors from zero and {:.1} % of the peak |a| {} m/s^2: the \
                     accelerometer may have an offset (bias or tilt); subtract it or fit the \
                     `offset` component",
                    pre.len(),
                    rows[0],
                    rows[first - 1],
                    num(mean),
                    if se > 0.0 {
                        mean.abs() / se
                    } else {
                        f64::INFINITY
                    },
                    100.0 * mean.abs() / peak,
                    num(peak)
                ),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ModelSpec, Params};
    use rand::{rngs::StdRng, RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};

    const DT: f64 = 0.005;

    /// `theta` (full model) released after `rest` samples of noise-only
    /// rest, 2001 samples in all, with noise of `noise` times the peak.
    fn released(theta: &[f64], noise: f64, rest: usize, seed: u64) -> Record {
        let mut rng = StdRng::seed_from_u64(seed);
        let syn = crate::data::synthesize(
            &crate::model::Model::from(ModelSpec::FULL),
            theta,
            DT,
            2001 - rest,
            noise,
            &mut rng,
        )
        .unwrap();
        let normal = Normal::new(0.0, syn.sigma).unwrap();
        let mut a: Vec<f64> = (0..rest).map(|_| normal.sample(&mut rng)).collect();
        a.extend_from_slice(syn.record.a());
        let t = (0..a.len()).map(|i| i as f64 * DT).collect();
        Record::new(t, a).unwrap()
    }

    fn test5(rest: usize) -> Record {
        let theta = Params::table_8_1(5).unwrap().to_theta(&ModelSpec::FULL);
        released(&theta, 0.015, rest, 7)
    }

    fn map(rec: &Record, f: impl Fn(usize, f64) -> f64) -> Record {
        let a = rec.a().iter().enumerate().map(|(i, &a)| f(i, a)).collect();
        Record::new(rec.t().to_vec(), a).unwrap()
    }

    fn warnings(rec: &Record) -> Vec<Warning> {
        record_warnings(rec, &rec.aligned(None).unwrap())
    }

    fn codes(rec: &Record) -> Vec<String> {
        warnings(rec).into_iter().map(|w| w.code).collect()
    }

    /// The only warning of `rec`, which must have `code`.
    fn only(rec: &Record, code: &str) -> String {
        let w = warnings(rec);
        assert_eq!(w.len(), 1, "{w:#?}");
        assert_eq!(w[0].code, code, "{w:#?}");
        w[0].message.clone()
    }

    /// Issue 37: the first 20 rows of a release were fitted with u0 3 times
    /// off and no word; the whole record raises no such warning.
    #[test]
    fn a_record_cut_to_its_first_swing_is_called_short() {
        let rec = test5(0);
        assert!(
            !codes(&rec).contains(&"short-record".to_string()),
            "{:#?}",
            warnings(&rec)
        );
        let head = Record::new(rec.t()[..20].to_vec(), rec.a()[..20].to_vec()).unwrap();
        let w = warnings(&head);
        let short = w
            .iter()
            .find(|w| w.code == "short-record")
            .expect("short-record");
        assert!(short.message.contains("(20 samples"), "{}", short.message);
    }

    /// The five Table 8.1 columns (Tests 3, 5, 6, 7, 8: the table has no
    /// others) and three random sets within 15 % of them.
    fn parameter_sets() -> Vec<Vec<f64>> {
        let spec = ModelSpec::FULL;
        let mut sets: Vec<Vec<f64>> = [3, 5, 6, 7, 8]
            .iter()
            .map(|&k| Params::table_8_1(k).unwrap().to_theta(&spec))
            .collect();
        let mut rng = StdRng::seed_from_u64(81);
        while sets.len() < 8 {
            let mut theta = sets[rng.random_range(0..5)].clone();
            for v in theta.iter_mut() {
                *v *= 1.0 + 0.15 * (2.0 * rng.random::<f64>() - 1.0);
            }
            if spec.params_from_slice(&theta).is_ok() && spec.in_support(&theta) {
                sets.push(theta);
            }
        }
        sets
    }

    #[test]
    fn clean_release_tests_give_no_warnings() {
        for (k, theta) in parameter_sets().iter().enumerate() {
            for rest in [0, 150] {
                for seed in 0..3 {
                    let rec = released(theta, 0.015, rest, 100 * k as u64 + seed);
                    let w = warnings(&rec);
                    assert!(w.is_empty(), "set {k} rest {rest} seed {seed}: {w:#?}");
                }
            }
        }
    }

    #[test]
    fn a_time_column_in_milliseconds_or_hours_is_flagged() {
        let rec = test5(0);
        // Milliseconds (a step of 5 "s") are refused outright (issue 37: the
        // search ran for over 11 minutes); a coarse step is a warning.
        let ms = Record::new(
            rec.t().iter().map(|t| t * 1000.0).collect(),
            rec.a().to_vec(),
        )
        .unwrap();
        let e = ms.aligned(None).unwrap_err().to_string();
        assert!(
            e.contains("time step is 5 s") && e.contains("milliseconds"),
            "{e}"
        );
        let coarse = Record::new(rec.t().iter().map(|t| t * 16.0).collect(), rec.a().to_vec());
        let msg = only(&coarse.unwrap(), "sampling-interval");
        assert!(
            msg.contains("step 0.08000 s (12.50 Hz) is too coarse"),
            "{msg}"
        );
        assert!(
            msg.contains("in milliseconds, the step is 0.08000 ms (12500 Hz)"),
            "{msg}"
        );
        let h = Record::new(
            rec.t().iter().map(|t| t / 3600.0).collect(),
            rec.a().to_vec(),
        );
        let msg = only(&h.unwrap(), "sampling-interval");
        assert!(
            msg.contains("step 1.389e-6 s (7.200e5 Hz) is implausibly fine"),
            "{msg}"
        );
        assert!(
            msg.contains("in minutes the step is 8.333e-5 s, in hours 0.005000 s"),
            "{msg}"
        );
    }

    #[test]
    fn a_record_in_g_or_mm_is_flagged_with_the_unit_that_fits() {
        // Released from 2.5 cm: peak 0.30 m/s^2, 0.031 g.
        let rec = map(&test5(0), |_, a| 0.25 * a);
        let peak = rec.a().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(codes(&rec).is_empty());
        let in_g = map(&rec, |_, a| a / 9.80665);
        let msg = only(&in_g, "acceleration-units");
        let expected = format!(
            "the peak |a| after the release, {} m/s^2, is below the 0.1500 to 50.00 m/s^2",
            num(peak / 9.80665)
        );
        assert!(msg.starts_with(&expected), "{msg}\n{expected}");
        assert!(msg.contains(&format!(
            "probably in g: read that way its peak is {} m/s^2 (--accel-units g)",
            num(peak)
        )));
        assert!(codes(&in_g.in_units(AccelUnits::G).unwrap()).is_empty());

        let in_mm = map(&rec, |_, a| a * 1000.0);
        let msg = only(&in_mm, "acceleration-units");
        assert!(msg.contains("is above the 0.1500 to 50.00 m/s^2"), "{msg}");
        assert!(msg.contains("--accel-units mm/s2"), "{msg}");
        let back = in_mm.in_units("mm/s2".parse().unwrap()).unwrap();
        assert!(codes(&back).is_empty());

        let absurd = map(&rec, |_, a| a * 1e7);
        assert!(only(&absurd, "acceleration-units").contains("no unit of m/s2, g, mm/s2"));
        // Test 5 in g (peak about 0.1) is caught; one with twice its peak
        // (about 0.2, plausible in m/s^2 too) cannot be told.
        assert_eq!(
            codes(&map(&test5(0), |_, a| a / 9.80665)),
            ["acceleration-units"]
        );
        assert!(codes(&map(&test5(0), |_, a| 2.0 * a / 9.80665)).is_empty());
    }

    #[test]
    fn glitches_are_listed_by_row() {
        let rec = test5(100);
        // 80 m/s^2: the peak that the units check sees leaves it out.
        let glitched = map(&rec, |i, a| if i == 1400 { 80.0 } else { a });
        let msg = only(&glitched, "outliers");
        assert!(
            msg.starts_with("1 single-sample outlier (glitch) at row 1402, up to"),
            "{msg}"
        );
        let (fixed, _) = glitched.without_outliers();
        assert!(codes(&fixed).is_empty());
        let many = map(&rec, |i, a| {
            if (300..1500).contains(&i) && i % 100 == 0 {
                a + 1.5
            } else {
                a
            }
        });
        let msg = only(&many, "outliers");
        assert!(
            msg.starts_with(
                "12 single-sample outliers (glitches) at rows 302, 402, 502, 602, 702, 802, \
                 902, 1002, 1102, 1202, ..., up to"
            ),
            "{msg}"
        );
    }

    #[test]
    fn an_offset_before_the_release_is_flagged_with_its_value() {
        let rec = test5(100);
        let peak = rec.a().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let off = map(&rec, |_, a| a + 0.03 * peak);
        let msg = only(&off, "dc-offset");
        let pre = &off.a()[..100];
        let mean = pre.iter().sum::<f64>() / 100.0;
        assert!(
            msg.starts_with(&format!(
                "the 100 samples before the release (rows 2-101) average {} m/s^2",
                num(mean)
            )),
            "{msg}"
        );
        // Under 1 % of the peak it is left alone, however many samples.
        assert!(codes(&map(&rec, |_, a| a + 0.005 * peak)).is_empty());
        // Too few samples before the release to judge.
        let short = map(&test5(8), |_, a| a + 0.03 * peak);
        assert!(codes(&short).is_empty());
    }

    #[test]
    fn pure_noise_shows_no_release() {
        let mut rng = StdRng::seed_from_u64(5);
        // Peaks under 0.05 m/s^2 too, but no unit is blamed for noise.
        let normal = Normal::new(0.0, 0.002).unwrap();
        let t: Vec<f64> = (0..4000).map(|i| i as f64 * DT).collect();
        let a = t.iter().map(|_| normal.sample(&mut rng)).collect();
        let rec = Record::new(t, a).unwrap();
        // The half-peak rule finds a "release" early in the noise.
        assert!(rec.detect_release() < 200);
        let msg = only(&rec, "no-release");
        assert!(msg.contains("times the noise level 0.0020"), "{msg}");
    }

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(num(0.019669), "0.01967");
        assert_eq!(num(2.38581), "2.386");
        assert_eq!(num(6.2313e-5), "6.231e-5");
        assert_eq!(num(-1234.5), "-1234");
        assert_eq!(num(720000.0), "7.200e5");
        assert_eq!(num(0.0), "0");
    }

    #[test]
    fn units_parse_and_print() {
        for u in AccelUnits::ALL {
            assert_eq!(u.as_str().parse::<AccelUnits>(), Ok(u));
            assert_eq!(u.to_string(), u.as_str());
        }
        assert_eq!("M/S^2".parse(), Ok(AccelUnits::MetresPerSecondSquared));
        let err = "gal".parse::<AccelUnits>().unwrap_err().to_string();
        assert_eq!(
            err,
            "unknown acceleration unit `gal`: expected m/s2, g or mm/s2"
        );
        assert_eq!(AccelUnits::G.factor(), 9.80665);
        let w = Warning::new("x-y", "z".into());
        assert_eq!(w.to_string(), "warning [x-y]: z");
        assert_eq!(
            serde_json::to_string(&w).unwrap(),
            r#"{"code":"x-y","message":"z"}"#
        );
    }
}
