//! A measured release-test record: time and acceleration, read from CSV or
//! whitespace-separated text, validated row by row, and aligned to the
//! release instant.
//!
//! Accepted layouts:
//! - CSV with a header naming columns `t` (s) and `a` (m/s^2); other columns
//!   are ignored;
//! - whitespace-separated text, with the same header or with no header (then
//!   the first two columns are `t` and `a`). Lines starting with `#` are
//!   comments.
//!
//! Rows are numbered as lines of the file (the header is row 1). A UTF-8
//! byte-order mark before the first line is ignored. A record holds at most
//! [`MAX_SAMPLES`] samples.
//!
//! Single-sample outliers (glitches) are found by [`Record::outliers`]:
//! release detection ignores them, and [`Record::without_outliers`] replaces
//! them by the mean of their neighbours.
//!
//! ```
//! use hbis::data::Record;
//!
//! let text = "t,a\n0.0,-0.6\n0.005,-0.59\n0.01,-0.58\n";
//! let rec = Record::parse(text, 2).unwrap();
//! assert_eq!(rec.len(), 3);
//! assert_eq!(rec.a()[1], -0.59);
//! ```

use std::path::Path;

use thiserror::Error;

use crate::model::{ForwardModel, SimError};

/// Why a record could not be read or used.
#[derive(Debug, Error)]
pub enum RecordError {
    /// The file could not be read.
    #[error("cannot read record {path}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The header lacks a required column.
    #[error("header (row 1) has no column `{column}` (found: {found})")]
    Header { column: &'static str, found: String },
    /// The header names a column twice: which one holds the data is a guess.
    #[error(
        "header (row 1) names column `{column}` {count} times (found: {found}): rename all but one"
    )]
    DuplicateColumn {
        column: &'static str,
        count: usize,
        found: String,
    },
    /// The file is not UTF-8 text.
    #[error("{path}, line {line}: byte {byte} of the line is not UTF-8 text; save the record as UTF-8 (or ASCII) CSV")]
    NotUtf8 {
        path: String,
        line: usize,
        byte: usize,
    },
    /// The sampling step is too coarse for any release test.
    #[error("the time step is {dt} s after the release (rows {first_row}-{last_row}), coarser than the {max} s any release test needs; is the time column in milliseconds? (t must be in seconds)")]
    StepTooCoarse {
        dt: f64,
        max: f64,
        first_row: usize,
        last_row: usize,
    },
    /// A field is not a number.
    #[error("row {row}, column `{column}`: expected a number, found `{value}`")]
    Parse {
        row: usize,
        column: &'static str,
        value: String,
    },
    /// A row has too few fields.
    #[error("row {row}: expected at least {expected} fields, found {found}")]
    Fields {
        row: usize,
        expected: usize,
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("row {row}, column `{column}`: value {value} is not finite")]
    NonFinite {
        row: usize,
        column: &'static str,
        value: f64,
    },
    /// Time does not increase.
    #[error("row {row}: time {t} s does not increase (previous row has {previous} s)")]
    NonIncreasing { row: usize, t: f64, previous: f64 },
    /// Not enough samples to identify anything.
    #[error("{what}: {found} samples, need at least {min}")]
    TooFew {
        what: &'static str,
        found: usize,
        min: usize,
    },
    /// Sampling is not uniform.
    #[error("row {row}, column `t`: time {t} s is off the uniform grid (step {dt} s) by {off:.3e} s; hbis needs uniformly sampled records")]
    NonUniform {
        row: usize,
        t: f64,
        dt: f64,
        off: f64,
    },
    /// Time and acceleration vectors of different lengths.
    #[error("column `t` has {t} samples but column `a` has {a}")]
    Lengths { t: usize, a: usize },
    /// A time step far from the record's sampling step: missing samples
    /// (a gap) or an extra one. `row` is the first row after the step.
    #[error("row {row}, column `t`: time {t} s comes {step} s after the previous row, {ratio:.2} sampling steps of {dt} s ({hint}); hbis needs uniformly sampled records")]
    Step {
        row: usize,
        t: f64,
        step: f64,
        dt: f64,
        ratio: f64,
        hint: &'static str,
    },
    /// The record holds more samples than [`MAX_SAMPLES`].
    #[error("row {row}: the record has {found} samples, more than the limit of {max} (MAX_SAMPLES: 10,000 s at 200 Hz); cut it to the release test or decimate it")]
    TooMany {
        row: usize,
        found: usize,
        max: usize,
    },
    /// The acceleration does not vary from the release on: nothing moves.
    #[error("rows {first_row}-{last_row}, column `a`: the acceleration is constant ({value} m/s^2) from the release on; no free vibration to identify")]
    Constant {
        first_row: usize,
        last_row: usize,
        value: f64,
    },
    /// The acceleration is too large to square: every fit would overflow.
    #[error("row {row}, column `a`: {peak:e} m/s^2 is too large to fit (the squares of the samples after the release, rows {first_row}-{last_row}, overflow); check this sample and the record's scale")]
    TooLarge {
        row: usize,
        first_row: usize,
        last_row: usize,
        peak: f64,
    },
    /// A row asked for ([`Record::without_samples`]) holds no sample.
    #[error("row {row} holds no sample of the record (its samples are on rows {first}-{last})")]
    NoSuchRow {
        row: usize,
        first: usize,
        last: usize,
    },
    /// The given release time is outside the record.
    #[error("release time t0 = {t0} s is outside the record [{first}, {last}] s")]
    ReleaseOutside { t0: f64, first: f64, last: f64 },
}

/// Fewest samples after the release that a fit accepts.
pub const MIN_SAMPLES: usize = 20;

/// The coarsest sampling step a record may have (s): 10 Hz cannot follow
/// the reversals of a 1-3 s isolation period at all (steps above 0.05 s
/// are a warning, [`crate::data::validation::DT_RANGE`]). A time column in
/// milliseconds gives steps of 1 to 20 "s" and a search that never ends.
pub const MAX_STEP: f64 = 0.1;

/// Most samples a record may hold: a release test sampled at 200 Hz for
/// 10,000 s. A free-vibration release test lasts tens of seconds; a longer
/// record is a monitoring log to cut, and would only make every fit slow.
/// [`Record::parse`] stops at the first row past the limit.
pub const MAX_SAMPLES: usize = 2_000_000;

/// How many robust noise scales a sample must stand off both of its
/// neighbourhoods to be a single-sample outlier ([`Record::outliers`]).
pub const OUTLIER_THRESHOLD: f64 = 5.0;

/// A single-sample outlier (glitch) found by [`Record::outliers`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Outlier {
    /// Index of the sample in the record.
    pub index: usize,
    /// Row of the file it was read from.
    pub row: usize,
    /// Its time (s).
    pub t: f64,
    /// Its acceleration (m/s^2).
    pub a: f64,
    /// What its neighbours predict there (m/s^2): the mean of the straight
    /// lines through the two samples on either side.
    pub expected: f64,
}

/// A time series of measured acceleration.
#[derive(Debug, Clone)]
pub struct Record {
    t: Vec<f64>,
    a: Vec<f64>,
    rows: Vec<usize>,
}

/// How the release instant was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReleaseSource {
    /// Given by the user (`--t0`); the first sample at or after it is the first used.
    Given,
    /// Detected: the first sample whose |a| reaches half the record's peak
    /// (single-sample outliers ignored, see [`Record::detect_release`]).
    Detected,
}

impl ReleaseSource {
    /// `"given"` or `"detected"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ReleaseSource::Given => "given",
            ReleaseSource::Detected => "detected",
        }
    }
}

/// The part of a record after release, on a uniform grid: sample `i` is
/// `lag + i dt` after the release.
#[derive(Debug, Clone)]
pub struct Aligned {
    /// Release time in the record's clock (s).
    pub t0: f64,
    /// Time of the first sample used, in the record's clock (s).
    pub t_first: f64,
    /// How `t0` was chosen.
    pub source: ReleaseSource,
    /// Time from the release to the first sample used (s), in `[0, dt)`: a
    /// release rarely falls on a sample instant. Given `t0`, it is known;
    /// detected, it starts at 0 and a fit estimates it
    /// ([`crate::inference::release`]).
    pub lag: f64,
    /// Index of the first sample used.
    pub first_index: usize,
    /// Sampling step (s).
    pub dt: f64,
    /// `1`, or `-1` when the record starts with a positive acceleration:
    /// released towards negative displacement, or the sensor points the
    /// other way. The model is odd in `(u, v, a)`, so such a record is the
    /// mirror image of a release from `|u0|`, and `a` holds it mirrored:
    /// every fit sees the paper's convention (`u0 > 0`, `a(0) < 0`).
    pub polarity: f64,
    /// Whether a fit has placed a detected release ([`Aligned::placed`]):
    /// later fits keep the lag.
    pub lag_placed: bool,
    /// Measured acceleration (m/s^2) at `t0 + lag + i dt`, times `polarity`.
    pub a: Vec<f64>,
}

impl Aligned {
    /// Whether the release instant is known only to lie between the last
    /// sample before the detected release and the first one after it.
    pub fn lag_unknown(&self) -> bool {
        self.lag_detected() && !self.lag_placed
    }

    /// Whether the release was detected after the record's first sample,
    /// so its lag is an estimate (placed or not).
    pub fn lag_detected(&self) -> bool {
        self.source == ReleaseSource::Detected && self.first_index > 0
    }

    /// The same samples with a detected release placed `lag` s before the
    /// first one by a fit: later fits keep it.
    pub fn placed(self, lag: f64) -> Self {
        Self {
            lag_placed: true,
            ..self.with_lag(lag)
        }
    }

    /// The same samples with the release `lag` s before the first one.
    pub fn with_lag(mut self, lag: f64) -> Self {
        self.t0 = self.t_first - lag;
        self.lag = lag;
        self
    }

    /// `v` (model or record, fit frame) in the record's own sign.
    pub fn in_record_sign(&self, v: &[f64]) -> Vec<f64> {
        v.iter().map(|x| self.polarity * x).collect()
    }

    /// `model`'s acceleration at `theta` on this record's samples (`lag +
    /// i dt` after the release), written into `out`: every comparison of a
    /// model with the record goes through here, so none forgets the lag.
    pub fn model_accel_into<M: ForwardModel + ?Sized>(
        &self,
        model: &M,
        theta: &[f64],
        out: &mut [f64],
    ) -> Result<(), SimError> {
        model.accel_grid_into(theta, self.lag, self.dt, out)
    }

    /// `sum_i (a_i - model_i)^2` at `theta` on this record's samples, where
    /// the model forms it without storing its acceleration
    /// ([`ForwardModel::sse_grid`]); `None` otherwise.
    pub fn model_sse<M: ForwardModel + ?Sized>(
        &self,
        model: &M,
        theta: &[f64],
    ) -> Option<Result<f64, SimError>> {
        model.sse_grid(theta, self.lag, self.dt, &self.a)
    }

    /// Time of sample `i` in the record's clock (s).
    pub fn time(&self, i: usize) -> f64 {
        self.t_first + i as f64 * self.dt
    }

    /// Sum of squared measured accelerations, the denominator of `e2`.
    pub fn energy(&self) -> f64 {
        self.a.iter().map(|v| v * v).sum()
    }

    /// Duration covered (s).
    pub fn duration(&self) -> f64 {
        self.dt * (self.a.len().saturating_sub(1)) as f64
    }
}

/// Refuses a record of `n` samples, more than [`MAX_SAMPLES`], in the words
/// of the file reader (rows numbered from 2): a caller holding arrays checks
/// before copying them.
pub fn check_size(n: usize) -> Result<(), RecordError> {
    if n > MAX_SAMPLES {
        return Err(RecordError::TooMany {
            row: MAX_SAMPLES + 2,
            found: n,
            max: MAX_SAMPLES,
        });
    }
    Ok(())
}

impl Record {
    /// A record from time and acceleration vectors (rows numbered from 2;
    /// at most [`MAX_SAMPLES`]).
    pub fn new(t: Vec<f64>, a: Vec<f64>) -> Result<Self, RecordError> {
        if t.len() != a.len() {
            return Err(RecordError::Lengths {
                t: t.len(),
                a: a.len(),
            });
        }
        check_size(t.len())?;
        let rows = (0..t.len()).map(|i| i + 2).collect();
        let rec = Self { t, a, rows };
        rec.validate()?;
        Ok(rec)
    }

    /// Reads a record file (CSV or whitespace-separated text).
    pub fn read(path: &Path) -> Result<Self, RecordError> {
        let bytes = std::fs::read(path).map_err(|source| RecordError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let head = &e.as_bytes()[..at];
            let line_start = head.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            RecordError::NotUtf8 {
                path: path.display().to_string(),
                line: 1 + head.iter().filter(|&&b| b == b'\n').count(),
                byte: 1 + at - line_start,
            }
        })?;
        Self::parse(&text, 2)
    }

    /// Parses record text; `min` is the fewest samples accepted. A UTF-8
    /// byte-order mark is skipped; more than [`MAX_SAMPLES`] samples is an
    /// error ([`RecordError::TooMany`]), found without parsing the rest.
    pub fn parse(text: &str, min: usize) -> Result<Self, RecordError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
            .peekable();
        fn split(l: &str) -> Vec<&str> {
            if l.contains(',') {
                l.split(',').map(|s| s.trim().trim_matches('"')).collect()
            } else {
                l.split_whitespace().collect()
            }
        }
        let (mut it, mut ia) = (0, 1);
        if let Some((_, first)) = lines.peek() {
            let fields = split(first);
            let numeric = fields.iter().all(|f| f.parse::<f64>().is_ok());
            if !numeric {
                let find = |name: &'static str| {
                    fields
                        .iter()
                        .position(|f| f.eq_ignore_ascii_case(name))
                        .ok_or_else(|| RecordError::Header {
                            column: name,
                            found: fields.join(", "),
                        })
                };
                it = find("t")?;
                ia = find("a")?;
                for name in ["t", "a"] {
                    let count = fields
                        .iter()
                        .filter(|f| f.eq_ignore_ascii_case(name))
                        .count();
                    if count > 1 {
                        return Err(RecordError::DuplicateColumn {
                            column: name,
                            count,
                            found: fields.join(", "),
                        });
                    }
                }
                lines.next();
            }
        }
        let need = it.max(ia) + 1;
        let (mut t, mut a, mut rows) = (Vec::new(), Vec::new(), Vec::new());
        while let Some((row, line)) = lines.next() {
            if t.len() == MAX_SAMPLES {
                return Err(RecordError::TooMany {
                    row,
                    found: MAX_SAMPLES + 1 + lines.by_ref().count(),
                    max: MAX_SAMPLES,
                });
            }
            let fields = split(line);
            if fields.len() < need {
                return Err(RecordError::Fields {
                    row,
                    expected: need,
                    found: fields.len(),
                });
            }
            let num = |i: usize, column: &'static str| {
                fields[i].parse::<f64>().map_err(|_| RecordError::Parse {
                    row,
                    column,
                    value: fields[i].to_string(),
                })
            };
            t.push(num(it, "t")?);
            a.push(num(ia, "a")?);
            rows.push(row);
        }
        let rec = Self { t, a, rows };
        rec.validate()?;
        if rec.len() < min {
            return Err(RecordError::TooFew {
                what: "record",
                found: rec.len(),
                min,
            });
        }
        Ok(rec)
    }

    fn validate(&self) -> Result<(), RecordError> {
        for i in 0..self.t.len() {
            let row = self.rows[i];
            for (column, value) in [("t", self.t[i]), ("a", self.a[i])] {
                if !value.is_finite() {
                    return Err(RecordError::NonFinite { row, column, value });
                }
            }
            if i > 0 && self.t[i] <= self.t[i - 1] {
                return Err(RecordError::NonIncreasing {
                    row,
                    t: self.t[i],
                    previous: self.t[i - 1],
                });
            }
        }
        Ok(())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when the record holds no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Times (s).
    pub fn t(&self) -> &[f64] {
        &self.t
    }

    /// Accelerations (m/s^2).
    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// The file row of each sample (the header is row 1; [`Record::new`]
    /// numbers samples from row 2).
    pub fn rows(&self) -> &[usize] {
        &self.rows
    }

    /// The same record with every acceleration multiplied by `factor`
    /// (e.g. [`crate::data::AccelUnits::factor`]); an error names the first
    /// row whose product is not finite.
    pub fn scaled(mut self, factor: f64) -> Result<Self, RecordError> {
        for (a, &row) in self.a.iter_mut().zip(&self.rows) {
            let value = *a * factor;
            if !value.is_finite() {
                return Err(RecordError::NonFinite {
                    row,
                    column: "a",
                    value,
                });
            }
            *a = value;
        }
        Ok(self)
    }

    /// The same record read as acceleration in `units`, converted to m/s^2.
    pub fn in_units(self, units: crate::data::AccelUnits) -> Result<Self, RecordError> {
        let factor = units.factor();
        if factor == 1.0 {
            Ok(self)
        } else {
            self.scaled(factor)
        }
    }

    /// Second differences `d[j] = a[j-1] - 2 a[j] + a[j+1]` at
    /// `j = 1..n-1` (stored at `j - 1`), and their robust scale: 1.4826
    /// times their median absolute deviation, the standard deviation for
    /// Gaussian noise (`sqrt(6)` times the noise's own), floored at `1e-9`
    /// of the peak |a| so that a noise-free record does not divide by zero.
    fn second_differences(&self) -> (Vec<f64>, f64) {
        let a = &self.a;
        if a.len() < 3 {
            return (Vec::new(), f64::MIN_POSITIVE);
        }
        let d: Vec<f64> = a.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
        let scale = robust_scale(&d);
        (d, scale.max(1e-9 * self.peak()).max(f64::MIN_POSITIVE))
    }

    /// Peak |a| (m/s^2).
    fn peak(&self) -> f64 {
        self.a.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    /// Standard deviation of white measurement noise, estimated from the
    /// second differences (robust scale over `sqrt(6)`): the smooth motion
    /// and the steps of the acceleration hardly move it.
    pub fn noise_level(&self) -> f64 {
        self.second_differences().1 / 6f64.sqrt()
    }

    /// Single-sample outliers (glitches), in record order.
    ///
    /// Let `L = 2 a[i-1] - a[i-2]` and `R = 2 a[i+1] - a[i+2]` be the
    /// straight lines through the two neighbours on either side of sample
    /// `i`, and `s` the robust scale of the second differences (the larger
    /// of the whole record's and that of the samples where |a| exceeds a
    /// tenth of the peak, when there are at least [`MIN_SAMPLES`] of them;
    /// see [`Record::noise_level`]). Sample `i` is an outlier when
    /// - it stands more than [`OUTLIER_THRESHOLD`] `s` off both `L` and
    ///   `R`, on the same side;
    /// - `L` and `R` agree: `|L - R|` is at most `OUTLIER_THRESHOLD s`
    ///   plus half the smaller deviation;
    /// - its own second difference bends the other way by more than
    ///   `OUTLIER_THRESHOLD s` (a curve or a kink bends one way throughout);
    /// - neither neighbour is an outlier.
    ///
    /// A step of the acceleration, as at the release or at every velocity
    /// reversal (`2 F_F / m`), has the sample on one of the two lines, so
    /// it is never an outlier; nor is a glitch two samples long. The first
    /// two and last two samples are not tested.
    ///
    /// With white noise of standard deviation `sigma`, `s = sqrt(6) sigma`:
    /// a glitch is found when it exceeds about `5 s`, 12 `sigma` (at 1.5 %
    /// noise, a fifth of the peak), and pure Gaussian noise yields a false
    /// one far less than once in 10^9 samples.
    pub fn outliers(&self) -> Vec<Outlier> {
        let mask = self.outlier_mask();
        let (d, _) = self.second_differences();
        mask.iter()
            .enumerate()
            .filter(|(_, &m)| m)
            .map(|(i, _)| Outlier {
                index: i,
                row: self.rows[i],
                t: self.t[i],
                a: self.a[i],
                // a[i] - L = d[i-2] and a[i] - R = d[i]
                expected: self.a[i] - 0.5 * (d[i - 2] + d[i]),
            })
            .collect()
    }

    /// `true` at every sample [`Record::outliers`] finds.
    fn outlier_mask(&self) -> Vec<bool> {
        let n = self.len();
        let mut flag = vec![false; n];
        if n < 5 {
            return flag;
        }
        let (d, noise) = self.second_differences();
        // Where the record moves (|a| above a tenth of its peak), the
        // second differences also hold the curvature of the motion and the
        // kinks of yielding, which a coarse sampling makes large: the scale
        // is the larger of the whole record's and of these samples', so
        // that a record mostly at rest does not judge its motion by the
        // noise of its rest alone. A few such samples are a glitch or a
        // burst, not a motion: they do not count.
        let peak = self.peak();
        let moving: Vec<f64> = (1..n - 1)
            .filter(|&j| self.a[j].abs() >= 0.1 * peak)
            .map(|j| d[j - 1])
            .collect();
        let s = if moving.len() >= MIN_SAMPLES {
            noise.max(robust_scale(&moving))
        } else {
            noise
        };
        let k = OUTLIER_THRESHOLD;
        for i in 2..n - 2 {
            // Deviations of a[i] from the lines through its left and right pairs.
            let (dl, dr) = (d[i - 2], d[i]);
            let small = dl.abs().min(dr.abs());
            // A spike g makes the second differences (g, -2 g, g) around
            // it; a kink or a curve keeps them of one sign.
            flag[i] = dl.signum() == dr.signum()
                && small > k * s
                && (dl - dr).abs() <= 0.5 * small + k * s
                && d[i - 1] * dl.signum() < -k * s;
        }
        (0..n)
            .map(|i| flag[i] && !(i > 0 && flag[i - 1]) && !(i + 1 < n && flag[i + 1]))
            .collect()
    }

    /// The same record with the samples on file rows `rows` replaced by
    /// the straight line between the nearest samples kept on either side
    /// (the mean of its two neighbours for an isolated sample; the nearest
    /// kept sample at either end). Replacing rather than removing keeps the
    /// time grid uniform, which every fit needs; the replaced samples keep
    /// their rows.
    pub fn without_samples(&self, rows: &[usize]) -> Result<Self, RecordError> {
        let n = self.len();
        let mut drop = vec![false; n];
        for &row in rows {
            match self.rows.binary_search(&row) {
                Ok(i) => drop[i] = true,
                Err(_) => {
                    return Err(RecordError::NoSuchRow {
                        row,
                        first: self.rows.first().copied().unwrap_or(0),
                        last: self.rows.last().copied().unwrap_or(0),
                    })
                }
            }
        }
        let kept: Vec<usize> = (0..n).filter(|&i| !drop[i]).collect();
        if kept.is_empty() && n > 0 {
            return Err(RecordError::TooFew {
                what: "samples kept",
                found: 0,
                min: 1,
            });
        }
        let mut a = self.a.clone();
        for i in (0..n).filter(|&i| drop[i]) {
            let after = kept.partition_point(|&j| j < i);
            a[i] = match (after.checked_sub(1).map(|p| kept[p]), kept.get(after)) {
                (Some(l), Some(&r)) => {
                    let w = (self.t[i] - self.t[l]) / (self.t[r] - self.t[l]);
                    self.a[l] + w * (self.a[r] - self.a[l])
                }
                (Some(l), None) => self.a[l],
                (None, Some(&r)) => self.a[r],
                (None, None) => unreachable!("some sample is kept"),
            };
        }
        Ok(Self {
            t: self.t.clone(),
            a,
            rows: self.rows.clone(),
        })
    }

    /// The record with its [`Record::outliers`] replaced as
    /// [`Record::without_samples`] does (each by the mean of its two
    /// neighbours), and the outliers it replaced.
    pub fn without_outliers(&self) -> (Self, Vec<Outlier>) {
        let outliers = self.outliers();
        let rows: Vec<usize> = outliers.iter().map(|o| o.row).collect();
        let rec = self
            .without_samples(&rows)
            .expect("outliers are samples of the record, and never all of it");
        (rec, outliers)
    }

    /// Index of the detected release: the first sample whose |a| reaches
    /// half the record's peak |a|. Before release the mass is held, so the
    /// record shows noise only; release applies the largest restoring force
    /// of the test at once, so the acceleration jumps within one sample.
    /// Single-sample outliers ([`Record::outliers`]) are ignored.
    pub fn detect_release(&self) -> usize {
        self.detect_release_masked(&self.outlier_mask())
    }

    fn detect_release_masked(&self, outlier: &[bool]) -> usize {
        let peak = self
            .a
            .iter()
            .zip(outlier)
            .filter(|(_, &o)| !o)
            .fold(0.0f64, |m, (v, _)| m.max(v.abs()));
        self.a
            .iter()
            .zip(outlier)
            .position(|(v, &o)| !o && v.abs() >= 0.5 * peak)
            .unwrap_or(0)
    }

    /// The samples from the release on, checked to lie on a uniform grid.
    /// `t0 = None` detects the release. Single-sample outliers are ignored
    /// in detecting it and in choosing the polarity, but stay in
    /// [`Aligned::a`] (see [`Record::without_outliers`]). A record constant
    /// from the release on is an error ([`RecordError::Constant`]): no fit
    /// can use it.
    pub fn aligned(&self, t0: Option<f64>) -> Result<Aligned, RecordError> {
        if self.is_empty() {
            return Err(RecordError::TooFew {
                what: "samples after the release",
                found: 0,
                min: MIN_SAMPLES,
            });
        }
        let outlier = self.outlier_mask();
        let (first, source) = match t0 {
            Some(t0) => {
                let (lo, hi) = (self.t[0], self.t[self.len() - 1]);
                if !(t0 >= lo - 1e-9 && t0 <= hi) {
                    return Err(RecordError::ReleaseOutside {
                        t0,
                        first: lo,
                        last: hi,
                    });
                }
                let i = self.t.partition_point(|&t| t < t0 - 1e-9);
                (i, ReleaseSource::Given)
            }
            None => (
                self.detect_release_masked(&outlier),
                ReleaseSource::Detected,
            ),
        };
        let t = &self.t[first..];
        let n = t.len();
        if n < MIN_SAMPLES {
            return Err(RecordError::TooFew {
                what: "samples after the release",
                found: n,
                min: MIN_SAMPLES,
            });
        }
        let dt = self.check_grid(first)?;
        let after = &self.a[first..];
        if after.iter().all(|&v| v == after[0]) {
            return Err(RecordError::Constant {
                first_row: self.rows[first],
                last_row: self.rows[self.len() - 1],
                value: after[0],
            });
        }
        if !after.iter().map(|v| v * v).sum::<f64>().is_finite() {
            let (i, peak) = after
                .iter()
                .map(|v| v.abs())
                .enumerate()
                .fold((0, 0.0f64), |m, (i, v)| if v > m.1 { (i, v) } else { m });
            return Err(RecordError::TooLarge {
                row: self.rows[first + i],
                first_row: self.rows[first],
                last_row: self.rows[self.len() - 1],
                peak,
            });
        }
        if dt > MAX_STEP {
            return Err(RecordError::StepTooCoarse {
                dt,
                max: MAX_STEP,
                first_row: self.rows[first],
                last_row: self.rows[self.len() - 1],
            });
        }
        let t0 = t0.unwrap_or(t[0]).min(t[0]);
        // Released from u0 > 0 the spring pulls back: the first samples are
        // negative, and near the record's peak.
        let head: f64 = after
            .iter()
            .zip(&outlier[first..])
            .filter(|(_, &o)| !o)
            .take(5)
            .map(|(a, _)| a)
            .sum();
        let polarity = if head > 0.0 { -1.0 } else { 1.0 };
        Ok(Aligned {
            t0,
            t_first: t[0],
            source,
            lag: t[0] - t0,
            first_index: first,
            dt,
            polarity,
            lag_placed: false,
            a: after.iter().map(|a| polarity * a).collect(),
        })
    }

    /// Checks that the samples from index `first` on (at least two) lie on
    /// a uniform grid, and returns its step. Each time step is first
    /// compared with the median step, so a gap or an extra sample is
    /// reported at the row where it occurs (a step estimated from the
    /// ends would be biased by the gap, and every row drift off its grid);
    /// then every time must lie within 1 % of the step of the grid through
    /// the first and last samples.
    fn check_grid(&self, first: usize) -> Result<f64, RecordError> {
        let t = &self.t[first..];
        let n = t.len();
        let steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let typical = median(&mut steps.clone());
        for (i, &step) in steps.iter().enumerate() {
            let ratio = step / typical;
            if (ratio - 1.0).abs() > 0.1 {
                let hint = if ratio > 1.5 {
                    "missing samples?"
                } else if ratio < 0.5 {
                    "an extra or repeated sample?"
                } else {
                    "a time off the sampling grid?"
                };
                return Err(RecordError::Step {
                    row: self.rows[first + i + 1],
                    t: t[i + 1],
                    step: round_sig(step),
                    dt: round_sig(typical),
                    ratio,
                    hint,
                });
            }
        }
        let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
        for (i, &ti) in t.iter().enumerate() {
            let off = ti - (t[0] + i as f64 * dt);
            if off.abs() > 0.01 * dt {
                return Err(RecordError::NonUniform {
                    row: self.rows[first + i],
                    t: ti,
                    dt,
                    off,
                });
            }
        }
        Ok(dt)
    }

    /// Writes the record as CSV with header `t,a`.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("t,a\n");
        for (t, a) in self.t.iter().zip(&self.a) {
            s.push_str(&format!("{t},{a}\n"));
        }
        s
    }
}

/// `x` to 9 significant digits, for messages: a step read as
/// `0.006200000000000004` is shown as `0.0062`.
fn round_sig(x: f64) -> f64 {
    format!("{x:.8e}").parse().unwrap_or(x)
}

/// 1.4826 times the median absolute deviation of `v`: its standard
/// deviation for Gaussian values, hardly moved by a few wild ones.
pub(crate) fn robust_scale(v: &[f64]) -> f64 {
    let med = median(&mut v.to_vec());
    1.4826 * median(&mut v.iter().map(|x| (x - med).abs()).collect::<Vec<_>>())
}

/// Median of `v` (reordered); 0 when empty.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        hi
    } else {
        let lo = v[..n / 2].iter().fold(f64::NEG_INFINITY, |m, &x| m.max(x));
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> String {
        let mut s = String::from("t,a,other\n");
        for i in 0..n {
            let a = if i < 10 {
                0.001
            } else {
                -0.6 + 0.001 * i as f64
            };
            s.push_str(&format!("{},{a},x\n", i as f64 * 0.005));
        }
        s
    }

    /// Issue 37: each of these read as something else without a word.
    #[test]
    fn hostile_records_are_refused_naming_the_place() {
        let e = Record::parse("t,a,a\n0,1,2\n", 1).unwrap_err().to_string();
        assert!(e.contains("names column `a` 2 times"), "{e}");
        let mut text = String::from("t,a\n");
        for i in 0..300 {
            let a = if i == 150 {
                1e308
            } else {
                (0.02 * i as f64).cos()
            };
            text += &format!("{},{a}\n", i as f64 * 0.005);
        }
        let e = Record::parse(&text, 2)
            .unwrap()
            .aligned(Some(0.0))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("row 152, column `a`: 1e308"), "{e}");
        // Milliseconds in the time column: a step of 5 "s".
        let ms: String = (0..300)
            .map(|i| format!("{},{}\n", 5 * i, (0.02 * i as f64).cos()))
            .collect();
        let e = Record::parse(&ms, 2)
            .unwrap()
            .aligned(Some(0.0))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("time step is 5 s") && e.contains("milliseconds"),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, b"t,a\n0,1\n0.01,\xff2\n").unwrap();
        let e = Record::read(&path).unwrap_err().to_string();
        assert!(e.contains("line 3: byte 6 of the line is not UTF-8"), "{e}");
        // Just above MAX_STEP: 0.2 s (5 Hz) is refused too.
        let coarse: String = (0..300)
            .map(|i| format!("{},{}\n", 0.2 * i as f64, (0.02 * i as f64).cos()))
            .collect();
        let e = Record::parse(&coarse, 2)
            .unwrap()
            .aligned(Some(0.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("coarser than the 0.1 s"), "{e}");
    }

    #[test]
    fn reads_csv_and_whitespace_text_alike() {
        let csv = Record::parse(&grid(40), 2).unwrap();
        let ws_text = grid(40).replace(',', "  ").replace("  x", "");
        let ws = Record::parse(&ws_text, 2).unwrap();
        assert_eq!(csv.t(), ws.t());
        assert_eq!(csv.a(), ws.a());
        let headless = "# comment\n0 1.0\n0.1 2.0\n0.2 3.0\n";
        assert_eq!(Record::parse(headless, 2).unwrap().a(), &[1.0, 2.0, 3.0]);
    }

    #[test]
    fn errors_name_the_row_and_column() {
        let msg = |text: &str| Record::parse(text, 2).unwrap_err().to_string();
        assert!(msg("t,a\n0,1\n0.1,abc\n").contains("row 3, column `a`"));
        assert!(msg("t,a\n0,1\n0.1,NaN\n").contains("row 3, column `a`: value NaN"));
        assert!(msg("t,a\n0,1\n0.1,2\n0.1,3\n").contains("row 4: time 0.1 s does not increase"));
        assert!(msg("time,acc\n0,1\n").contains("no column `t`"));
        assert!(msg("t,a\n0,1\n").contains("1 samples, need at least 2"));
        assert!(msg("t,a\n0,1\n0.1\n").contains("row 3: expected at least 2 fields"));
    }

    #[test]
    fn release_is_detected_or_given() {
        let rec = Record::parse(&grid(60), 2).unwrap();
        let al = rec.aligned(None).unwrap();
        assert_eq!((al.first_index, al.source), (10, ReleaseSource::Detected));
        assert!((al.t0 - 0.05).abs() < 1e-12 && (al.dt - 0.005).abs() < 1e-12);
        let given = rec.aligned(Some(0.0201)).unwrap();
        assert_eq!((given.first_index, given.source), (5, ReleaseSource::Given));
        // The given release lies 4.9 ms before the first sample used.
        assert!((given.t0 - 0.0201).abs() < 1e-15 && (given.lag - 0.0049).abs() < 1e-12);
        assert!(al.lag == 0.0 && al.lag_unknown() && !given.lag_unknown());
        assert_eq!(al.polarity, 1.0);
        let mirrored: Vec<f64> = rec.a().iter().map(|a| -a).collect();
        let flip = Record::new(rec.t().to_vec(), mirrored).unwrap();
        let fl = flip.aligned(None).unwrap();
        assert_eq!((fl.polarity, fl.first_index), (-1.0, 10));
        assert_eq!(fl.a, al.a);
        let moved = al.with_lag(0.002);
        assert!((moved.t0 - 0.048).abs() < 1e-12 && moved.lag == 0.002);
        assert!(rec.aligned(Some(9.0)).is_err());
    }

    #[test]
    fn non_uniform_sampling_is_refused_with_its_row() {
        let mut text = String::from("t,a\n");
        for i in 0..30 {
            let t = if i == 7 { 0.0362 } else { i as f64 * 0.005 };
            text.push_str(&format!("{t},-0.5\n"));
        }
        let err = Record::parse(&text, 2).unwrap().aligned(None).unwrap_err();
        assert!(err.to_string().starts_with("row 9, column `t`:"), "{err}");
    }

    /// Test `k` of Table 8.1 released at `t = 0.5 s` after 100 samples of
    /// rest, 2001 samples in all, with noise of `noise` times the peak.
    fn released(k: u32, noise: f64, seed: u64) -> Record {
        use crate::model::{ModelSpec, Params};
        use rand::{rngs::StdRng, SeedableRng};
        use rand_distr::{Distribution, Normal};
        let spec = ModelSpec::FULL;
        let theta = Params::table_8_1(k).unwrap().to_theta(&spec);
        let mut rng = StdRng::seed_from_u64(seed);
        let syn = crate::data::synthesize(
            &crate::model::Model::from(spec),
            &theta,
            0.005,
            1901,
            noise,
            &mut rng,
        )
        .unwrap();
        let rest = Normal::new(0.0, syn.sigma.max(1e-300)).unwrap();
        let mut a: Vec<f64> = (0..100).map(|_| rest.sample(&mut rng)).collect();
        a.extend_from_slice(syn.record.a());
        let t = (0..a.len()).map(|i| i as f64 * 0.005).collect();
        Record::new(t, a).unwrap()
    }

    fn peak(rec: &Record) -> f64 {
        rec.a().iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    fn with_sample(rec: &Record, i: usize, value: f64) -> Record {
        let mut a = rec.a().to_vec();
        a[i] = value;
        Record::new(rec.t().to_vec(), a).unwrap()
    }

    #[test]
    fn a_byte_order_mark_and_crlf_line_ends_are_accepted() {
        let text = "\u{feff}t,a\r\n0,-0.5\r\n0.005,-0.49\r\n";
        let rec = Record::parse(text, 2).unwrap();
        assert_eq!(rec.a(), &[-0.5, -0.49]);
        let ws = Record::parse("\u{feff}t a\n0 1\n1 2\n", 2).unwrap();
        assert_eq!(ws.t(), &[0.0, 1.0]);
        let headless = Record::parse("\u{feff}0 1\n1 2\n", 2).unwrap();
        assert_eq!(headless.a(), &[1.0, 2.0]);
    }

    #[test]
    fn a_late_gap_is_reported_at_its_row() {
        // 1000 samples at 5 ms with samples 800 and 801 missing: sample 799
        // is on row 801, the first after the gap on row 802.
        let mut text = String::from("t,a\n");
        for i in (0..1000).filter(|i| !(800..802).contains(i)) {
            text.push_str(&format!(
                "{},{}\n",
                i as f64 * 0.005,
                -0.5 + 1e-4 * i as f64
            ));
        }
        let rec = Record::parse(&text, 2).unwrap();
        for t0 in [None, Some(0.0)] {
            let err = rec.aligned(t0).unwrap_err().to_string();
            assert!(err.starts_with("row 802, column `t`: time 4.01 s"), "{err}");
            assert!(
                err.contains("3.00 sampling steps of 0.005 s (missing samples?)"),
                "{err}"
            );
        }
        // Released after the gap, the record is uniform.
        assert_eq!(rec.aligned(Some(4.01)).unwrap().first_index, 800);
        // A repeated sample halves a step.
        let mut text = String::from("t,a\n");
        for i in 0..300 {
            text.push_str(&format!(
                "{},{}\n",
                i as f64 * 0.005,
                -0.5 + 1e-4 * i as f64
            ));
            if i == 250 {
                text.push_str(&format!("{},-0.4\n", i as f64 * 0.005 + 0.001));
            }
        }
        let err = Record::parse(&text, 2).unwrap().aligned(None).unwrap_err();
        assert!(err.to_string().starts_with("row 253, column `t`"), "{err}");
        assert!(
            err.to_string().contains("extra or repeated sample"),
            "{err}"
        );
    }

    #[test]
    fn more_than_max_samples_is_refused_with_the_count() {
        let extra = 3;
        let mut text = String::with_capacity(12 * (MAX_SAMPLES + extra));
        text.push_str("t,a\n");
        for i in 0..MAX_SAMPLES + extra {
            text.push_str(&format!("{i},0\n"));
        }
        let err = Record::parse(&text, 2).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!(
                "row {}: the record has {} samples, more than the limit of {MAX_SAMPLES}",
                MAX_SAMPLES + 2,
                MAX_SAMPLES + extra
            )),
            "{err}"
        );
        // At the limit it is read.
        let at = text
            .lines()
            .take(MAX_SAMPLES + 1)
            .collect::<Vec<_>>()
            .join("\n");
        assert_eq!(Record::parse(&at, 2).unwrap().len(), MAX_SAMPLES);
    }

    #[test]
    fn a_clean_or_noisy_release_test_has_no_outliers() {
        for k in [3, 5, 6, 7, 8] {
            for (noise, seed) in [(0.0, 0), (0.015, k as u64), (0.05, 9)] {
                let rec = released(k, noise, seed);
                assert!(
                    rec.outliers().is_empty(),
                    "test {k} noise {noise}: {:?}",
                    rec.outliers()
                );
                assert_eq!(rec.detect_release(), 100);
            }
        }
    }

    #[test]
    fn two_million_samples_of_gaussian_noise_have_no_outliers() {
        use rand::{rngs::StdRng, SeedableRng};
        use rand_distr::{Distribution, Normal};
        let mut rng = StdRng::seed_from_u64(3);
        let normal = Normal::new(0.0, 0.01).unwrap();
        let a: Vec<f64> = (0..MAX_SAMPLES).map(|_| normal.sample(&mut rng)).collect();
        let t = (0..MAX_SAMPLES).map(|i| i as f64 * 0.005).collect();
        let rec = Record::new(t, a).unwrap();
        assert!(rec.outliers().is_empty());
        assert!(
            (rec.noise_level() / 0.01 - 1.0).abs() < 0.01,
            "{}",
            rec.noise_level()
        );
    }

    #[test]
    fn coarse_noise_free_records_have_no_outliers() {
        // At 50 and 20 Hz the curvature and the yield kinks of the motion
        // make second differences far above those of the 15 s of rest
        // after the mass stops: judged by the rest alone, some would pass
        // for glitches.
        use crate::model::{ModelSpec, Params};
        use rand::{rngs::StdRng, SeedableRng};
        let spec = ModelSpec::FULL;
        for k in [3, 5, 6, 7, 8] {
            let theta = Params::table_8_1(k).unwrap().to_theta(&spec);
            for dt in [0.02, 0.05] {
                let n = (20.0 / dt) as usize;
                let mut rng = StdRng::seed_from_u64(0);
                let syn = crate::data::synthesize(
                    &crate::model::Model::from(spec),
                    &theta,
                    dt,
                    n,
                    0.0,
                    &mut rng,
                )
                .unwrap();
                let o = syn.record.outliers();
                assert!(o.is_empty(), "test {k} dt {dt}: {o:?}");
            }
        }
    }

    #[test]
    fn curves_kinks_steps_and_bursts_are_not_outliers() {
        let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
        let rec = |a: Vec<f64>| Record::new(t.clone(), a).unwrap();
        // A uniformly curving acceleration: every second difference alike.
        let parabola: Vec<f64> = (0..200).map(|i| 1e-4 * (i as f64).powi(2)).collect();
        assert!(rec(parabola.clone()).outliers().is_empty());
        // A kink, from a line to the parabola.
        let kink = (0..200).map(|i| if i < 100 { 0.0 } else { parabola[i - 100] });
        assert!(rec(kink.collect()).outliers().is_empty());
        // A rounded kink, bending over three samples.
        let mut rounded = vec![0.0; 200];
        for j in 2..200 {
            let d = if (99..102).contains(&(j - 1)) {
                0.1
            } else {
                0.0
            };
            rounded[j] = 2.0 * rounded[j - 1] - rounded[j - 2] + d;
        }
        assert!(rec(rounded).outliers().is_empty());
        // A release: rest, then a jump onto a curve bending the same way.
        let release = (0..200).map(|i| if i < 50 { 0.0 } else { -1.0 - parabola[i - 50] });
        assert!(rec(release.collect()).outliers().is_empty());
        // A zig-zag burst of interference on noise: no single sample.
        let noisy: Vec<f64> = (0..200)
            .map(|i| 0.01 * ((i * 7919 % 101) as f64 / 101.0 - 0.5))
            .collect();
        let mut burst = noisy.clone();
        for (j, b) in burst[120..126].iter_mut().enumerate() {
            *b += if j % 2 == 0 { 0.5 } else { -0.5 };
        }
        assert!(rec(burst).outliers().is_empty());
        let mut one = noisy;
        one[120] += 0.5;
        assert_eq!(rec(one.clone()).outliers().len(), 1);
        // Two glitches on a quiet record: the only samples above a tenth
        // of the peak, they are no motion to scale the threshold by.
        one[40] -= 0.5;
        let found: Vec<usize> = rec(one).outliers().iter().map(|o| o.index).collect();
        assert_eq!(found, [40, 120]);
    }

    #[test]
    fn friction_steps_are_not_outliers() {
        // The noise-free Test 5 record jumps at each velocity reversal by
        // 2 F_F / m, a step of some hundred times its smooth change per sample.
        let rec = released(5, 0.0, 0);
        let a = rec.a();
        let d: Vec<f64> = a.windows(3).map(|w| w[0] - 2.0 * w[1] + w[2]).collect();
        let s = rec.second_differences().1;
        let steps = (2..d.len() - 1)
            .filter(|&j| d[j].abs() > 20.0 * s && (d[j] + d[j + 1]).abs() < 0.1 * d[j].abs())
            .count();
        assert!(steps >= 5, "{steps} steps");
        assert!(rec.outliers().is_empty());
        // A noisy staircase: steps of 10 noise levels, up and down.
        let t: Vec<f64> = (0..400).map(|i| i as f64 * 0.01).collect();
        let a: Vec<f64> = (0..400)
            .map(|i| {
                let level = if (i / 7) % 2 == 0 { 1.0 } else { -1.0 };
                level + 0.1 * ((i * 7919 % 101) as f64 / 101.0 - 0.5)
            })
            .collect();
        assert!(Record::new(t, a).unwrap().outliers().is_empty());
    }

    #[test]
    fn glitches_are_found_and_ignored_by_release_detection() {
        let clean = released(5, 0.015, 11);
        let p = peak(&clean);
        // Before the release, 0.8 of the peak: taken for the release by the
        // half-peak rule, 250 ms early.
        let early = with_sample(&clean, 50, -0.8 * p);
        let found = early.outliers();
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!((found[0].index, found[0].row), (50, 52));
        assert!(found[0].expected.abs() < 0.1 * p);
        assert_eq!(early.detect_release(), 100);
        let al = early.aligned(None).unwrap();
        assert_eq!((al.first_index, al.polarity), (100, 1.0));
        // Late, three times the peak: the half-peak rule would start there.
        let late = with_sample(&clean, 1500, 3.0 * p);
        assert_eq!(
            late.outliers().iter().map(|o| o.row).collect::<Vec<_>>(),
            [1502]
        );
        assert_eq!(late.aligned(None).unwrap().first_index, 100);
        // Just after the release, positive, larger than the four samples
        // around it: the polarity stays.
        let head = with_sample(&clean, 102, 6.0 * p);
        assert_eq!(head.outliers().len(), 1);
        assert_eq!(head.aligned(None).unwrap().polarity, 1.0);
        // Dropped, each is the mean of its neighbours.
        let (fixed, dropped) = late.without_outliers();
        assert_eq!(dropped.len(), 1);
        let a = fixed.a();
        assert_eq!(a[1500], 0.5 * (a[1499] + a[1501]));
        assert_eq!((fixed.t(), fixed.rows()), (late.t(), late.rows()));
        assert!(fixed.outliers().is_empty());
        // A glitch of two samples is not a single-sample outlier.
        let pair = with_sample(&late, 1501, 3.0 * p);
        assert!(pair.outliers().is_empty());
    }

    #[test]
    fn without_samples_keeps_the_grid_and_names_a_missing_row() {
        let rec =
            Record::new(vec![0.0, 1.0, 2.0, 3.0, 4.0], vec![0.0, 1.0, 9.0, 3.0, 5.0]).unwrap();
        let out = rec.without_samples(&[4, 6]).unwrap();
        assert_eq!(out.a(), &[0.0, 1.0, 2.0, 3.0, 3.0]);
        // Two neighbours dropped: the line between the nearest kept.
        assert_eq!(
            rec.without_samples(&[3, 4]).unwrap().a(),
            &[0.0, 1.0, 2.0, 3.0, 5.0]
        );
        assert_eq!(rec.without_samples(&[2]).unwrap().a()[0], 1.0);
        let err = rec.without_samples(&[7]).unwrap_err().to_string();
        assert_eq!(
            err,
            "row 7 holds no sample of the record (its samples are on rows 2-6)"
        );
        assert!(rec.without_samples(&[2, 3, 4, 5, 6]).is_err());
    }

    #[test]
    fn a_constant_record_cannot_be_aligned() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.01).collect();
        for value in [0.0, 0.3] {
            let rec = Record::new(t.clone(), vec![value; 50]).unwrap();
            let err = rec.aligned(None).unwrap_err().to_string();
            assert_eq!(
                err,
                format!(
                    "rows 2-51, column `a`: the acceleration is constant ({value} m/s^2) from \
                     the release on; no free vibration to identify"
                )
            );
        }
    }

    #[test]
    fn units_scale_the_acceleration() {
        use crate::data::AccelUnits;
        let rec = Record::new(vec![0.0, 1.0], vec![0.1, -2.0]).unwrap();
        let err = Record::new(vec![0.0, 1.0], vec![0.1]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "column `t` has 2 samples but column `a` has 1"
        );
        let empty = Record::new(vec![], vec![]).unwrap();
        assert!(empty.aligned(Some(0.0)).is_err() && empty.aligned(None).is_err());
        let g = rec.clone().in_units(AccelUnits::G).unwrap();
        assert_eq!(g.a(), &[0.980665, -19.6133]);
        let mm = rec.clone().in_units("mm/s^2".parse().unwrap()).unwrap();
        assert_eq!(mm.a(), &[1e-4, -2e-3]);
        let err = rec.scaled(1e308).unwrap_err().to_string();
        assert_eq!(err, "row 3, column `a`: value -inf is not finite");
    }
}
