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
//! Rows are numbered as lines of the file (the header is row 1).
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
    #[error("row {row}: time {t} s is off the uniform grid (step {dt} s) by {off:.3e} s; hbis needs uniformly sampled records")]
    NonUniform {
        row: usize,
        t: f64,
        dt: f64,
        off: f64,
    },
    /// The given release time is outside the record.
    #[error("release time t0 = {t0} s is outside the record [{first}, {last}] s")]
    ReleaseOutside { t0: f64, first: f64, last: f64 },
}

/// Fewest samples after the release that a fit accepts.
pub const MIN_SAMPLES: usize = 20;

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
    /// Detected: the first sample whose |a| reaches half the record's peak.
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

impl Record {
    /// A record from time and acceleration vectors (rows numbered from 2).
    pub fn new(t: Vec<f64>, a: Vec<f64>) -> Result<Self, RecordError> {
        let rows = (0..t.len()).map(|i| i + 2).collect();
        let rec = Self { t, a, rows };
        rec.validate()?;
        Ok(rec)
    }

    /// Reads a record file (CSV or whitespace-separated text).
    pub fn read(path: &Path) -> Result<Self, RecordError> {
        let text = std::fs::read_to_string(path).map_err(|source| RecordError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::parse(&text, 2)
    }

    /// Parses record text; `min` is the fewest samples accepted.
    pub fn parse(text: &str, min: usize) -> Result<Self, RecordError> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
            .peekable();
        let split = |l: &str| -> Vec<String> {
            if l.contains(',') {
                l.split(',')
                    .map(|s| s.trim().trim_matches('"').to_string())
                    .collect()
            } else {
                l.split_whitespace().map(str::to_string).collect()
            }
        };
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
                lines.next();
            }
        }
        let need = it.max(ia) + 1;
        let (mut t, mut a, mut rows) = (Vec::new(), Vec::new(), Vec::new());
        for (row, line) in lines {
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
                    value: fields[i].clone(),
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

    /// Index of the detected release: the first sample whose |a| reaches
    /// half the record's peak |a|. Before release the mass is held, so the
    /// record shows noise only; release applies the largest restoring force
    /// of the test at once, so the acceleration jumps within one sample.
    pub fn detect_release(&self) -> usize {
        let peak = self.a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.a
            .iter()
            .position(|v| v.abs() >= 0.5 * peak)
            .unwrap_or(0)
    }

    /// The samples from the release on, checked to lie on a uniform grid.
    /// `t0 = None` detects the release.
    pub fn aligned(&self, t0: Option<f64>) -> Result<Aligned, RecordError> {
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
            None => (self.detect_release(), ReleaseSource::Detected),
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
        let t0 = t0.unwrap_or(t[0]).min(t[0]);
        // Released from u0 > 0 the spring pulls back: the first samples are
        // negative, and near the record's peak.
        let head: f64 = self.a[first..(first + 5).min(self.len())].iter().sum();
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
            a: self.a[first..].iter().map(|a| polarity * a).collect(),
        })
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
        assert!(err.to_string().starts_with("row 9:"), "{err}");
    }
}
