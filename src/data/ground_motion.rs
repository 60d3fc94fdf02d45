//! Ground motions: the PEER NGA `.AT2` format, plain two-column `(t, ag)`
//! files, and a seeded generator of synthetic motions (Kanai-Tajimi
//! filtered white noise under an envelope) for demos and tests, since
//! records cannot be downloaded here.
//!
//! # Formula
//!
//! The Kanai-Tajimi filter (Kanai 1957, Tajimi 1960) shapes white noise
//! `w(t)` by one soil layer of frequency `omega_g` and damping `zeta_g`:
//!
//! ```text
//! x'' + 2 zeta_g omega_g x' + omega_g^2 x = -w(t)
//! ag(t) = e(t) * -(2 zeta_g omega_g x' + omega_g^2 x)      (then scaled to the PGA)
//! S(omega) = S0 (omega_g^4 + 4 zeta_g^2 omega_g^2 omega^2)
//!            / ((omega_g^2 - omega^2)^2 + 4 zeta_g^2 omega_g^2 omega^2)
//! ```
//!
//! with the Jennings-Housner-Tsai envelope `e(t)`: `(t/t1)^2` up to `t1`,
//! 1 up to `t2`, `exp(-c (t - t2))` after. The filter is advanced exactly
//! over each step with the noise held constant (zero-order hold, the
//! matrix exponential), so the spectrum does not depend on `dt` beyond
//! the hold.
//!
//! ```
//! use hbis::data::ground_motion::KanaiTajimi;
//!
//! let gm = KanaiTajimi::default().generate(7)?;
//! assert_eq!(gm.ag.len(), 4001); // 40 s at 100 Hz
//! assert!((gm.pga() - 0.3 * 9.80665).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

use nalgebra::{Matrix2, Vector2};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use thiserror::Error;

use super::validation::AccelUnits;

/// A ground acceleration sampled every `dt`, from `t = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundMotion {
    /// Sampling step (s).
    pub dt: f64,
    /// Ground acceleration (m/s^2) at `t_i = i dt`.
    pub ag: Vec<f64>,
    /// Where it came from (file, or the generator and its seed).
    pub source: String,
}

/// The sampling steps a ground motion may have (s): strong-motion records
/// are sampled at 50 to 200 Hz; outside this range the file's DT (or its
/// unit) is wrong, and a step of 1e-300 s would make every response zero.
pub const DT_LIMITS: (f64, f64) = (1e-5, 0.1);

/// Most samples of a ground motion, tail included (as many as a record may
/// have, [`crate::data::record::MAX_SAMPLES`]): 5.5 hours at 100 Hz.
pub const MAX_SAMPLES: usize = crate::data::record::MAX_SAMPLES;

/// Largest peak ground acceleration accepted (m/s^2): 10 g, over twice the
/// largest ever recorded. Above it the unit or the scale factor is wrong.
pub const MAX_PGA: f64 = 10.0 * 9.80665;

/// What is wrong with a ground-motion file or generator setting.
#[derive(Debug, Error)]
pub enum MotionError {
    /// The file could not be read.
    #[error("cannot read ground motion {path}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The AT2 header is not as PEER writes it.
    #[error("AT2 header, line {line}: {problem}")]
    Header {
        /// 1-based line.
        line: usize,
        /// What was expected.
        problem: String,
    },
    /// A value is not a finite number.
    #[error("line {line}: `{value}` is not a finite number")]
    Value {
        /// 1-based line.
        line: usize,
        /// The text.
        value: String,
    },
    /// The file ends inside a number.
    #[error("line {line}: `{last}` ends the file without a line end and is shorter than the value before it (`{before}`): the file was cut short; restore it, or end the file with a line end if `{last}` is complete")]
    CutShort {
        /// 1-based line of the last value.
        line: usize,
        /// The last value.
        last: String,
        /// The value before it.
        before: String,
    },
    /// The number of values does not match the header.
    #[error("the header says NPTS = {expected}, the file holds {found} values")]
    Count {
        /// NPTS.
        expected: usize,
        /// Values read.
        found: usize,
    },
    /// Times that do not advance by one step.
    #[error("row {row}: t = {t} s, expected {expected} s (one step of {dt} s after the row before; a motion must be uniformly sampled)")]
    Grid {
        /// 1-based row.
        row: usize,
        /// Its time.
        t: f64,
        /// The time one step on.
        expected: f64,
        /// The step of the first two rows.
        dt: f64,
    },
    /// Too few samples, or an invalid setting.
    #[error("{0}")]
    Invalid(String),
}

impl GroundMotion {
    /// Duration (s).
    pub fn duration(&self) -> f64 {
        self.dt * self.ag.len().saturating_sub(1) as f64
    }

    /// Peak ground acceleration |ag| (m/s^2), over the samples.
    pub fn pga(&self) -> f64 {
        self.ag.iter().fold(0.0, |m, a| m.max(a.abs()))
    }

    /// Multiplied by `factor` (a scale factor of a record).
    pub fn scaled(mut self, factor: f64) -> Result<Self, MotionError> {
        if !factor.is_finite() {
            return Err(MotionError::Invalid(format!(
                "scale factor {factor}: expected a finite number"
            )));
        }
        self.ag.iter_mut().for_each(|a| *a *= factor);
        let pga = self.pga();
        if pga > MAX_PGA {
            return Err(MotionError::Invalid(format!(
                "scale factor {factor}: the scaled motion's PGA is {pga:.4e} m/s^2 ({:.3e} g), above the {} g any earthquake reaches; check the factor and the motion's unit",
                pga / 9.80665,
                MAX_PGA / 9.80665
            )));
        }
        Ok(self)
    }

    /// Scaled to the peak ground acceleration `pga` (m/s^2), as a suite is
    /// scaled to each level of a fragility curve.
    pub fn scaled_to_pga(self, pga: f64) -> Result<Self, MotionError> {
        if !(pga.is_finite() && pga > 0.0) {
            return Err(MotionError::Invalid(format!(
                "PGA {pga}: expected a finite acceleration > 0 (m/s^2)"
            )));
        }
        let now = self.pga();
        if now.is_nan() || now <= 0.0 {
            return Err(MotionError::Invalid(format!(
                "{}: the motion is zero throughout, it cannot be scaled to a PGA",
                self.source
            )));
        }
        self.scaled(pga / now)
    }

    /// Every `.AT2` file in `dir` (not its subfolders), in the order of
    /// their names; `units` as in [`GroundMotion::read_at2`].
    pub fn read_at2_dir(dir: &Path, units: Option<AccelUnits>) -> Result<Vec<Self>, MotionError> {
        let entries = std::fs::read_dir(dir).map_err(|source| MotionError::Io {
            path: dir.display().to_string(),
            source,
        })?;
        let mut paths: Vec<std::path::PathBuf> = entries
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("at2")))
            .collect();
        paths.sort();
        if paths.is_empty() {
            return Err(MotionError::Invalid(format!(
                "{}: no .AT2 file in this folder",
                dir.display()
            )));
        }
        paths.iter().map(|p| Self::read_at2(p, units)).collect()
    }

    /// Reads a PEER NGA `.AT2` file. `units` overrides the unit the header
    /// names (`G` in every PEER file); `None` takes the header's.
    pub fn read_at2(path: &Path, units: Option<AccelUnits>) -> Result<Self, MotionError> {
        let text = read(path)?;
        let mut m = Self::parse_at2(&text, units)?;
        m.source = path.display().to_string();
        Ok(m)
    }

    /// Parses the text of an `.AT2` file: four header lines (the third
    /// names the unit, the fourth `NPTS= n, DT= dt SEC` or the older
    /// `n dt NPTS, DT`), then the values, several per line.
    pub fn parse_at2(text: &str, units: Option<AccelUnits>) -> Result<Self, MotionError> {
        let lines: Vec<&str> = text.lines().collect();
        if lines.len() < 4 {
            return Err(MotionError::Header {
                line: lines.len() + 1,
                problem: "expected four header lines (title, event, units, NPTS and DT)".into(),
            });
        }
        let header_units = {
            let l = lines[2].to_ascii_uppercase();
            // PEER writes every record in g; any other unit must be given.
            (l.contains("UNITS OF G") || l.trim_end().ends_with(" G")).then_some(AccelUnits::G)
        };
        let units = match (units, header_units) {
            (Some(u), _) => u,
            (None, Some(u)) => u,
            (None, None) => {
                return Err(MotionError::Header {
                    line: 3,
                    problem: format!(
                        "`{}` names no unit hbis reads (UNITS OF G): give the unit",
                        lines[2].trim()
                    ),
                })
            }
        };
        let (npts, dt) = npts_dt(lines[3])?;
        check_step(dt)?;
        if npts > MAX_SAMPLES {
            return Err(MotionError::Header {
                line: 4,
                problem: format!("NPTS = {npts}: more than the {MAX_SAMPLES} samples hbis reads"),
            });
        }
        // Never more than the text can hold, whatever NPTS claims.
        let mut ag = Vec::with_capacity(npts.min(text.len() / 2 + 1));
        let mut tail = text.split_whitespace().rev();
        if let (Some(last), Some(before)) = (tail.next(), tail.next()) {
            cut_short(text, lines.len(), last, before)?;
        }
        for (i, line) in lines.iter().enumerate().skip(4) {
            for field in line.split_whitespace() {
                let v: f64 = field
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| MotionError::Value {
                        line: i + 1,
                        value: field.to_string(),
                    })?;
                ag.push(v * units.factor());
            }
        }
        if ag.len() != npts {
            return Err(MotionError::Count {
                expected: npts,
                found: ag.len(),
            });
        }
        check_len(ag.len())?;
        Ok(Self {
            dt,
            ag,
            source: "AT2".into(),
        })
    }

    /// Reads a two-column file `t, ag` (comma- or whitespace-separated, an
    /// optional header row, `#` comments) in `units`, uniformly sampled.
    pub fn read_columns(path: &Path, units: AccelUnits) -> Result<Self, MotionError> {
        let text = read(path)?;
        let mut m = Self::parse_columns(&text, units)?;
        m.source = path.display().to_string();
        Ok(m)
    }

    /// Parses the text of a two-column file (see [`Self::read_columns`]).
    pub fn parse_columns(text: &str, units: AccelUnits) -> Result<Self, MotionError> {
        let mut t = Vec::new();
        let mut ag = Vec::new();
        // The last two `ag` fields as written (line, text): a cut file.
        let mut texts: (Field, Field) = (None, None);
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|f| !f.is_empty())
                .collect();
            let nums: Option<Vec<f64>> = fields.iter().take(2).map(|f| f.parse().ok()).collect();
            if t.len() >= MAX_SAMPLES {
                return Err(MotionError::Invalid(format!(
                    "line {}: more than the {MAX_SAMPLES} samples hbis reads",
                    i + 1
                )));
            }
            match nums {
                Some(v) if v.len() == 2 => {
                    for x in &v {
                        if !x.is_finite() {
                            return Err(MotionError::Value {
                                line: i + 1,
                                value: line.to_string(),
                            });
                        }
                    }
                    t.push(v[0]);
                    ag.push(v[1] * units.factor());
                    texts = (texts.1, Some((i + 1, fields[1])));
                }
                // A header row before any data.
                _ if t.is_empty() => continue,
                _ => {
                    return Err(MotionError::Value {
                        line: i + 1,
                        value: line.to_string(),
                    })
                }
            }
        }
        check_len(ag.len())?;
        if let (Some((_, before)), Some((line, last))) = texts {
            cut_short(text, line, last, before)?;
        }
        let dt = t[1] - t[0];
        if dt.is_nan() || dt <= 0.0 {
            return Err(MotionError::Grid {
                row: 2,
                t: t[1],
                expected: t[0],
                dt,
            });
        }
        check_step(dt)?;
        for (k, w) in t.windows(2).enumerate() {
            let expected = t[0] + (k + 1) as f64 * dt;
            if (w[1] - expected).abs() > 1e-6 * dt.max(expected.abs() * 1e-3) + 1e-9 {
                return Err(MotionError::Grid {
                    row: k + 2,
                    t: w[1],
                    expected,
                    dt,
                });
            }
        }
        Ok(Self {
            dt,
            ag,
            source: "columns".into(),
        })
    }
}

/// A value as written, with its 1-based line.
type Field<'a> = Option<(usize, &'a str)>;

fn read(path: &Path) -> Result<String, MotionError> {
    std::fs::read_to_string(path).map_err(|source| MotionError::Io {
        path: path.display().to_string(),
        source,
    })
}

fn check_len(n: usize) -> Result<(), MotionError> {
    if n < 2 {
        return Err(MotionError::Invalid(format!(
            "{n} samples: a ground motion needs at least 2"
        )));
    }
    Ok(())
}

/// Refuses a step outside [`DT_LIMITS`].
fn check_step(dt: f64) -> Result<(), MotionError> {
    let (lo, hi) = DT_LIMITS;
    if !(lo..=hi).contains(&dt) {
        return Err(MotionError::Invalid(format!(
            "time step {dt:e} s: a ground motion is sampled every {lo:e} to {hi} s (check DT and its unit)"
        )));
    }
    Ok(())
}

/// Refuses a file that ends inside a number: its last line has no line
/// end and its last value is shorter than the one before it. A number cut
/// short still parses (`1.6723E-01` cut to `1.6723` reads ten times too
/// large), so the length is the only trace of the cut.
fn cut_short(text: &str, line: usize, last: &str, before: &str) -> Result<(), MotionError> {
    if text.is_empty() || text.ends_with('\n') || last.len() >= before.len() {
        return Ok(());
    }
    Err(MotionError::CutShort {
        line,
        last: last.to_string(),
        before: before.to_string(),
    })
}

/// `NPTS= 4000, DT= .0100 SEC` or `4000 .0050 NPTS, DT`.
fn npts_dt(line: &str) -> Result<(usize, f64), MotionError> {
    let bad = |problem: &str| MotionError::Header {
        line: 4,
        problem: format!("`{}`: {problem}", line.trim()),
    };
    let upper = line.to_ascii_uppercase();
    let (n, dt) = if let (Some(a), Some(b)) = (upper.find("NPTS="), upper.find("DT=")) {
        let after = |k: usize| {
            upper[k..]
                .split(|c: char| c == ',' || c.is_whitespace())
                .find(|s| !s.is_empty())
                .map(str::to_string)
        };
        (after(a + 5), after(b + 3))
    } else {
        let mut nums = upper.split_whitespace().map(|s| s.trim_end_matches(','));
        (
            nums.next().map(str::to_string),
            nums.next().map(str::to_string),
        )
    };
    let n: usize = n
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| bad("expected NPTS, a whole number"))?;
    let dt: f64 = dt
        .and_then(|s| s.parse().ok())
        .filter(|d: &f64| d.is_finite() && *d > 0.0)
        .ok_or_else(|| bad("expected DT, a step in seconds > 0"))?;
    Ok((n, dt))
}

/// A synthetic ground motion: Kanai-Tajimi filtered white noise under the
/// Jennings-Housner-Tsai envelope, scaled to a peak ground acceleration
/// (see the module's formula).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KanaiTajimi {
    /// Ground frequency `f_g = omega_g / 2 pi` (Hz).
    pub f_g: f64,
    /// Ground damping ratio `zeta_g` (-).
    pub zeta_g: f64,
    /// Peak ground acceleration the motion is scaled to (m/s^2).
    pub pga: f64,
    /// Duration (s).
    pub duration: f64,
    /// Sampling step (s).
    pub dt: f64,
    /// End of the quadratic rise (s).
    pub t1: f64,
    /// End of the strong phase (s).
    pub t2: f64,
    /// Decay rate after `t2` (1/s).
    pub decay: f64,
}

impl Default for KanaiTajimi {
    /// A firm-soil motion (`f_g` 2.5 Hz, `zeta_g` 0.6; Kanai-Tajimi
    /// values for firm ground), PGA 0.3 g, 40 s at 100 Hz, strong phase
    /// 2-12 s, decay 0.3 /s.
    fn default() -> Self {
        Self {
            f_g: 2.5,
            zeta_g: 0.6,
            pga: 0.3 * 9.80665,
            duration: 40.0,
            dt: 0.01,
            t1: 2.0,
            t2: 12.0,
            decay: 0.3,
        }
    }
}

impl KanaiTajimi {
    /// The envelope at `t`.
    pub fn envelope(&self, t: f64) -> f64 {
        if t < self.t1 {
            (t / self.t1).powi(2)
        } else if t <= self.t2 {
            1.0
        } else {
            (-self.decay * (t - self.t2)).exp()
        }
    }

    fn check(&self) -> Result<(), MotionError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        let problems = [
            (ok(self.f_g), "f_g must be > 0 (Hz)"),
            (ok(self.zeta_g), "zeta_g must be > 0"),
            (ok(self.pga), "pga must be > 0 (m/s^2)"),
            (ok(self.duration), "duration must be > 0 (s)"),
            (
                ok(self.dt) && self.dt < self.duration,
                "dt must be > 0 and below the duration (s)",
            ),
            (
                ok(self.t1) && self.t1 <= self.t2,
                "the envelope needs 0 < t1 <= t2 (s)",
            ),
            (ok(self.decay), "decay must be > 0 (1/s)"),
        ];
        match problems.iter().find(|(good, _)| !good) {
            Some((_, why)) => Err(MotionError::Invalid(format!("Kanai-Tajimi motion: {why}"))),
            None => Ok(()),
        }
    }

    /// The motion of `seed` (the same seed, the same motion).
    pub fn generate(&self, seed: u64) -> Result<GroundMotion, MotionError> {
        self.check()?;
        check_step(self.dt)?;
        let steps = (self.duration / self.dt + 1e-9).floor();
        if steps >= MAX_SAMPLES as f64 {
            return Err(MotionError::Invalid(format!(
                "Kanai-Tajimi motion: {} s at {} s is more than the {MAX_SAMPLES} samples hbis generates",
                self.duration, self.dt
            )));
        }
        let n = steps as usize + 1;
        let w = 2.0 * std::f64::consts::PI * self.f_g;
        let (k, c) = (w * w, 2.0 * self.zeta_g * w);
        // State (x, x'); x'' = -k x - c x' - noise.
        let a = Matrix2::new(0.0, 1.0, -k, -c);
        let phi = (a * self.dt).exp();
        // Zero-order hold of the noise: Gamma = A^-1 (Phi - I) B, B = (0, -1).
        let gamma = a
            .try_inverse()
            .map(|ai| ai * (phi - Matrix2::identity()) * Vector2::new(0.0, -1.0))
            .ok_or_else(|| MotionError::Invalid("Kanai-Tajimi filter is singular".into()))?;
        let mut rng = StdRng::seed_from_u64(seed);
        let mut x: Vector2<f64> = Vector2::zeros();
        let mut ag = Vec::with_capacity(n);
        for i in 0..n {
            ag.push(-(k * x[0] + c * x[1]) * self.envelope(i as f64 * self.dt));
            let noise: f64 = StandardNormal.sample(&mut rng);
            x = phi * x + gamma * noise;
        }
        let peak = ag.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if peak.is_nan() || peak <= 0.0 {
            return Err(MotionError::Invalid(
                "Kanai-Tajimi motion: the record is zero (duration too short?)".into(),
            ));
        }
        let s = self.pga / peak;
        ag.iter_mut().for_each(|v| *v *= s);
        Ok(GroundMotion {
            dt: self.dt,
            ag,
            source: format!(
                "Kanai-Tajimi (f_g {} Hz, zeta_g {}, PGA {} m/s^2, {} s at dt {} s), seed {seed}",
                self.f_g, self.zeta_g, self.pga, self.duration, self.dt
            ),
        })
    }
}

/// The seed of motion `j` (0-based) of the suite of seed `seed`: nearby
/// seeds give unrelated suites (splitmix64 of both), so suites of seeds 1
/// and 2 share no motion.
///
/// ```
/// use hbis::data::ground_motion::suite_seed;
/// assert_ne!(suite_seed(1, 1), suite_seed(2, 0));
/// assert_eq!(suite_seed(7, 3), suite_seed(7, 3));
/// ```
pub fn suite_seed(seed: u64, j: usize) -> u64 {
    use crate::inference::sample::mix;
    mix(mix(seed) ^ j as u64)
}

impl KanaiTajimi {
    /// `n` motions of this generator, motion `j` of seed
    /// [`suite_seed`]`(seed, j)`: a suite for record-to-record variability.
    pub fn suite(&self, n: usize, seed: u64) -> Result<Vec<GroundMotion>, MotionError> {
        (0..n).map(|j| self.generate(suite_seed(seed, j))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AT2: &str = "PEER NGA STRONG MOTION DATABASE RECORD\n\
Imperial Valley, 5/19/1940, El Centro, 180\n\
ACCELERATION TIME SERIES IN UNITS OF G\n\
NPTS=     7, DT=   .0100 SEC\n\
  .0063   .0036   .0010  -.0011  -.0029\n\
  -.0045  1.2E-03\n";

    #[test]
    fn reads_an_at2_file_in_g_and_its_older_header() {
        let m = GroundMotion::parse_at2(AT2, None).unwrap();
        assert_eq!(m.dt, 0.01);
        assert_eq!(m.ag.len(), 7);
        assert!((m.ag[0] - 0.0063 * 9.80665).abs() < 1e-15);
        assert!((m.ag[6] - 0.0012 * 9.80665).abs() < 1e-15);
        let old = AT2.replace("NPTS=     7, DT=   .0100 SEC", "7    0.0100    NPTS, DT");
        assert_eq!(GroundMotion::parse_at2(&old, None).unwrap(), m);
        let si = GroundMotion::parse_at2(AT2, Some(AccelUnits::MetresPerSecondSquared)).unwrap();
        assert_eq!(si.ag[0], 0.0063);
    }

    #[test]
    fn bad_at2_files_name_the_line_and_what_was_expected() {
        let cases = [
            (
                AT2.replace("NPTS=     7", "NPTS=     8"),
                "NPTS = 8, the file holds 7",
            ),
            (AT2.replace("-.0029", "-.00x9"), "line 5: `-.00x9`"),
            (AT2.replace("DT=   .0100", "DT=   -1"), "expected DT"),
            (AT2.replace("IN UNITS OF G", "IN FURLONGS"), "line 3"),
            ("PEER\nonly two lines\n".to_string(), "four header lines"),
        ];
        for (text, expect) in cases {
            let e = GroundMotion::parse_at2(&text, None)
                .unwrap_err()
                .to_string();
            assert!(e.contains(expect), "{expect}: {e}");
        }
    }

    /// Issue 37: sizes, steps, cut files and scales that used to abort or
    /// give a silently wrong motion.
    #[test]
    fn hostile_motions_are_refused_before_any_allocation() {
        let fixed = "PEER\nx\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS=     3, DT=   .0100 SEC\n  1.8700000E-01  1.6723000E-01  1.6723000E-01\n";
        let cases = [
            (
                AT2.replace("NPTS=     7", "NPTS= 1000000000000000"),
                "NPTS = 1000000000000000: more than",
            ),
            (
                AT2.replace("NPTS=     7", "NPTS= 9000000000000000000"),
                "more than the 2000000",
            ),
            (
                AT2.replace("DT=   .0100", "DT=   1e-300"),
                "time step 1e-300 s",
            ),
            (AT2.replace("DT=   .0100", "DT=   10"), "time step 1e1 s"),
            (fixed.trim_end().to_string() + "X", "`1.6723000E-01X`"),
            (
                fixed.trim_end()[..fixed.trim_end().len() - 4].to_string(),
                "the file was cut short",
            ),
        ];
        for (text, expect) in cases {
            let e = GroundMotion::parse_at2(&text, None)
                .unwrap_err()
                .to_string();
            assert!(e.contains(expect), "{expect}: {e}");
        }
        // Complete values without a final line end are read.
        let m = GroundMotion::parse_at2(fixed.trim_end(), None).unwrap();
        assert!((m.pga() - 0.187 * 9.80665).abs() < 1e-12);
        let e = GroundMotion::parse_columns("0 0.1875\n0.01 0.1672\n0.02 0.16", AccelUnits::G)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 3: `0.16`") && e.contains("cut short"),
            "{e}"
        );
        let e = GroundMotion::parse_columns("0 0.1\n1e-300 0.2\n", AccelUnits::G)
            .unwrap_err()
            .to_string();
        assert!(e.contains("time step 1e-300 s"), "{e}");
        let e = m.scaled(1e10).unwrap_err().to_string();
        assert!(
            e.contains("scale factor 10000000000") && e.contains("PGA"),
            "{e}"
        );
        let huge = KanaiTajimi {
            duration: 1e15,
            ..KanaiTajimi::default()
        };
        let e = huge.generate(1).unwrap_err().to_string();
        assert!(e.contains("more than the 2000000 samples"), "{e}");
        let coarse = KanaiTajimi {
            dt: 0.5,
            ..KanaiTajimi::default()
        };
        let e = coarse.generate(1).unwrap_err().to_string();
        assert!(e.contains("time step 5e-1 s"), "{e}");
    }

    /// Issue 37: a two-column file longer than any motion is refused at
    /// its first sample too many.
    #[test]
    fn a_two_column_motion_of_more_than_max_samples_is_refused() {
        let text: String = (0..=MAX_SAMPLES)
            .map(|i| format!("{} 0.1\n", i as f64 * 0.01))
            .collect();
        let e = GroundMotion::parse_columns(&text, AccelUnits::G)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2000001: more than the 2000000 samples"),
            "{e}"
        );
    }

    #[test]
    fn reads_two_columns_and_refuses_a_non_uniform_grid() {
        let m = GroundMotion::parse_columns("t,ag\n0,0.1\n0.02,0.2\n0.04,-0.1\n", AccelUnits::G)
            .unwrap();
        assert_eq!(m.dt, 0.02);
        assert!((m.ag[1] - 0.2 * 9.80665).abs() < 1e-15);
        let e = GroundMotion::parse_columns(
            "0 0\n0.01 1\n0.03 2\n",
            AccelUnits::MetresPerSecondSquared,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("row 3") && e.contains("uniformly sampled"),
            "{e}"
        );
        let e = GroundMotion::parse_columns("0 0\nx y\n", AccelUnits::G)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2: `x y`"), "{e}");
        let e = GroundMotion::parse_columns("t ag\n0 0\n", AccelUnits::G)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 2"), "{e}");
    }

    #[test]
    fn kanai_tajimi_is_seeded_scaled_and_enveloped() {
        let kt = KanaiTajimi::default();
        let a = kt.generate(3).unwrap();
        assert_eq!(a, kt.generate(3).unwrap());
        assert_ne!(a.ag, kt.generate(4).unwrap().ag);
        assert!((a.pga() - kt.pga).abs() < 1e-12);
        assert_eq!(a.ag[0], 0.0);
        // The coda decays with the envelope: the last 5 s hold a small
        // fraction of the strong phase's energy.
        let energy = |t0: f64, t1: f64| -> f64 {
            a.ag[(t0 / a.dt) as usize..(t1 / a.dt) as usize]
                .iter()
                .map(|v| v * v)
                .sum()
        };
        assert!(energy(35.0, 40.0) < 0.01 * energy(2.0, 12.0));
        assert!(KanaiTajimi { t1: 20.0, ..kt }.generate(1).is_err());
    }

    /// The generated spectrum peaks at the ground frequency for a lightly
    /// damped soil: the periodogram averaged over 40 seeds of the strong
    /// phase, smoothed over 0.25 Hz, is highest within 10 % of `f_g`.
    #[test]
    fn kanai_tajimi_spectrum_peaks_at_the_ground_frequency() {
        let kt = KanaiTajimi {
            f_g: 3.0,
            zeta_g: 0.15,
            t1: 0.01,
            t2: 40.0,
            ..KanaiTajimi::default()
        };
        let n = 2048;
        let mut power = vec![0.0; n / 2];
        for seed in 0..40 {
            let m = kt.generate(seed).unwrap();
            let x = &m.ag[500..500 + n];
            let mut buf: Vec<rustfft::num_complex::Complex<f64>> = x
                .iter()
                .map(|v| rustfft::num_complex::Complex::new(*v, 0.0))
                .collect();
            rustfft::FftPlanner::new()
                .plan_fft_forward(n)
                .process(&mut buf);
            for (p, c) in power.iter_mut().zip(&buf) {
                *p += c.norm_sqr();
            }
        }
        let df = 1.0 / (n as f64 * kt.dt);
        let half = (0.125 / df).round() as usize;
        let smooth = |k: usize| -> f64 {
            power[k.saturating_sub(half)..(k + half + 1).min(power.len())]
                .iter()
                .sum()
        };
        let peak = (1..power.len())
            .max_by(|&a, &b| smooth(a).total_cmp(&smooth(b)))
            .unwrap();
        let f = peak as f64 * df;
        assert!(
            (f - kt.f_g).abs() < 0.1 * kt.f_g,
            "peak at {f} Hz, f_g {} Hz",
            kt.f_g
        );
    }
}
