//! Where a fitted model disagrees with the record, and how.
//!
//! From the record, the model's acceleration at the MAP and the closed-form
//! base response there (phases, displacement, velocity, reversals):
//!
//! - residual size overall, by phase and by half-cycle (with its amplitude);
//! - half-cycle periods of the record beside the model's, against amplitude
//!   (the amplitude-dependent frequency);
//! - the acceleration jump at each reversal, record beside model (the
//!   friction signature);
//! - a restoring-force residual map: the mean residual force per unit mass
//!   over bins of displacement and velocity (after Masri & Caughey's
//!   restoring-force surface);
//! - whiteness (Ljung-Box, 20 lags) and the residual spectrum with its
//!   dominant frequency, and whether the model can produce it;
//! - a short verdict in the user's terms.
//!
//! # Formula
//! ```text
//! Ljung-Box: Q = n (n + 2) sum_(k=1..h) rho_k^2 / (n - k),  p = P(chi2_h > Q)
//! jump at a reversal (velocity changes sign between samples i-1 and i;
//! i-1 where that sample lies on the reversal, `reversals`):
//!   line through a[i+2..=i+6] minus line through a[i-6..=i-2], both at
//!   i - 1/2   (the model at its reversal i; the record at its own break
//!   c, |c - i| <= 4, where two lines split a[i-10..=i+10] best, when
//!   that beats the split at i by more than 9 noise variances)
//! ```
//! The lines keep a wrong stiffness (another slope of the acceleration on
//! either side) out of the jump; a sample is left out on each side so that
//! a record reversing a sample off its measured break keeps its jump
//! outside the lines. A model whose periods are off reverses several
//! samples away from the record: measured at the model's reversal, the
//! record's lines straddled its jump (a wrong spring law then showed
//! jumps 8 % of the model's at one reversal and a false direction
//! dependence). The structure features and the verdict are in
//! [`super::features`].

use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

use super::features::{self, Feature};
use crate::data::record::{median, robust_scale};
use crate::model::numeric::Motion;
use crate::model::{ModelSpec, Params, SimError};

/// Residual size of one group of samples.
#[derive(Debug, Clone, Serialize)]
pub struct GroupResidual {
    /// Group name (a phase, or `half-cycle k`).
    pub group: String,
    /// Samples in the group.
    pub samples: usize,
    /// RMS residual (m/s^2).
    pub rms: f64,
    /// Mean residual (m/s^2).
    pub mean: f64,
}

/// One half-cycle.
#[derive(Debug, Clone, Serialize)]
pub struct HalfCycle {
    /// Index (0: release to first reversal).
    pub index: usize,
    /// Largest |u| in it, model at the MAP (m).
    pub amplitude: f64,
    /// RMS residual in it (m/s^2).
    pub rms: f64,
    /// Time between the |a| peaks that bound it, record (s).
    pub period_record: Option<f64>,
    /// The same on the model's acceleration (s).
    pub period_model: Option<f64>,
    /// The record regressed on the model in it, `<a, m> / <m, m>`: its
    /// size relative to the model's, unbiased by noise.
    pub gain: f64,
    /// The standard error of `gain`, `rms / sqrt(<m, m>)`.
    pub gain_se: f64,
    /// Its start, time after the release (s).
    pub start: f64,
    /// Its end (s).
    pub end: f64,
    /// How late the record runs against the model in it (s; negative:
    /// early), `-<r, dm/dt> / <dm/dt, dm/dt>` away from the reversals.
    pub shift: f64,
    /// The standard error of `shift` (s).
    pub shift_se: f64,
}

/// The acceleration jump at one reversal.
#[derive(Debug, Clone, Serialize)]
pub struct Jump {
    /// Reversal time (s after release).
    pub t: f64,
    /// Displacement there, model (m).
    pub u: f64,
    /// Jump in the record (m/s^2).
    pub record: f64,
    /// Jump in the model (m/s^2).
    pub model: f64,
}

/// The residual's spectrum in brief.
#[derive(Debug, Clone, Serialize)]
pub struct Spectrum {
    /// Frequency of the largest periodogram peak above 0.05 Hz (Hz).
    pub dominant_frequency_hz: f64,
    /// Its share of the residual power (within ±5 % of it).
    pub dominant_share: f64,
    /// The share white noise puts in the same band (its frequency bins
    /// over all): near the Nyquist frequency about a tenth, so only the
    /// share above it marks a peak.
    pub white_share: f64,
    /// Frequencies the model produces (its `f0, f1, f2`, Hz).
    pub model_frequencies_hz: Vec<f64>,
    /// Whether the dominant frequency is within 15 % of a model frequency or
    /// of its second or third harmonic.
    pub model_can_produce: bool,
}

/// Residual diagnostics of one fit.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnostics {
    /// `e2` of the fit.
    pub e2: f64,
    /// RMS residual (m/s^2).
    pub rms: f64,
    /// Mean residual (m/s^2).
    pub mean: f64,
    /// Residual mean over the samples at rest (m/s^2), if the model rests.
    pub mean_at_rest: Option<f64>,
    /// By phase of motion.
    pub by_phase: Vec<GroupResidual>,
    /// By half-cycle.
    pub half_cycles: Vec<HalfCycle>,
    /// At each reversal.
    pub jumps: Vec<Jump>,
    /// The noise level: the median absolute second difference of the
    /// residual over `0.6745 sqrt(6 - 8 rho + 2 rho^2)` (`rho` of the fitted
    /// AR(1) noise, 0 for white), m/s^2.
    pub noise_sd: f64,
    /// Noise sd of one jump, `noise_sd sqrt(3.65)` (two line
    /// extrapolations).
    pub jump_sd: f64,
    /// Ljung-Box statistic over 20 lags (of the whitened residual when the
    /// fit has AR(1) noise: `whitened_rho`).
    pub ljung_box_q: f64,
    /// Its p-value (small: the residual is not white).
    pub ljung_box_p: f64,
    /// Lag-one autocorrelation of the residual (whitened as the Ljung-Box
    /// statistic is).
    pub lag1: f64,
    /// Lag-one autocorrelation of the residual itself.
    pub lag1_raw: f64,
    /// The fitted AR(1) coefficient the residual was whitened with before
    /// judging its whiteness (`e_i - rho e_(i-1)`); `None` for white noise.
    pub whitened_rho: Option<f64>,
    /// Dominant residual frequency (Hz), as in `spectrum`.
    pub dominant_frequency_hz: f64,
    /// The spectrum.
    pub spectrum: Spectrum,
    /// Restoring-force residual map: `u` bin edges (m).
    pub map_u_edges: Vec<f64>,
    /// `v` bin edges (m/s).
    pub map_v_edges: Vec<f64>,
    /// Mean residual force per unit mass `-(a_meas - a_model)` per bin
    /// (`[u bin][v bin]`, NaN where empty), N/kg.
    pub map_force: Vec<Vec<f64>>,
    /// The residual's structure, measured ([`super::features`]).
    pub features: Vec<Feature>,
    /// The verdict.
    pub verdict: String,
}

/// Computes the diagnostics. `measured` and `model` are sampled every `dt`
/// from the release; `motion` is the model's motion on the same grid
/// ([`crate::model::Model::motion_grid`]: phases, displacement, velocity,
/// with every force component acting); `spec` and `base` give the spring's
/// frequencies; `whiten` is the fitted AR(1) coefficient, if any.
pub fn diagnose(
    spec: &ModelSpec,
    base: &Params,
    motion: &[Motion],
    measured: &[f64],
    model: &[f64],
    dt: f64,
    whiten: Option<f64>,
) -> Result<Diagnostics, SimError> {
    let n = measured.len().min(model.len()).min(motion.len());
    if n < 3 {
        return Err(SimError::Grid {
            name: "samples",
            value: n as f64,
            requirement: "at least 3 samples of record, model and motion are needed",
        });
    }
    let r: Vec<f64> = (0..n).map(|i| measured[i] - model[i]).collect();
    let energy: f64 = measured[..n].iter().map(|v| v * v).sum();
    let sse: f64 = r.iter().map(|v| v * v).sum();
    let rms = (sse / n as f64).sqrt();
    let mean = r.iter().sum::<f64>() / n as f64;
    let samples = &motion[..n];
    // Groups by phase.
    let mut by_phase: Vec<GroupResidual> = Vec::new();
    for (s, v) in samples.iter().zip(&r) {
        let name = s.phase.as_str();
        match by_phase.iter_mut().find(|g| g.group == name) {
            Some(g) => {
                g.samples += 1;
                g.rms += v * v;
                g.mean += v;
            }
            None => by_phase.push(GroupResidual {
                group: name.to_string(),
                samples: 1,
                rms: v * v,
                mean: *v,
            }),
        }
    }
    for g in by_phase.iter_mut() {
        g.rms = (g.rms / g.samples as f64).sqrt();
        g.mean /= g.samples as f64;
    }
    let mean_at_rest = by_phase.iter().find(|g| g.group == "rest").map(|g| g.mean);
    // Half-cycles and reversals (velocity sign changes of the model).
    let rev = reversals(samples, dt);
    let mut bounds = vec![0usize];
    bounds.extend(&rev);
    bounds.push(samples.len());
    let peak_times = |a: &[f64]| -> Vec<f64> {
        // Time of the largest |a| near each reversal (the release included).
        bounds[..bounds.len() - 1]
            .iter()
            .map(|&b| {
                let lo = b.saturating_sub(20);
                let hi = (b + 20).min(a.len());
                let i = (lo..hi)
                    .max_by(|&x, &y| a[x].abs().total_cmp(&a[y].abs()))
                    .unwrap_or(b);
                i as f64 * dt
            })
            .collect()
    };
    let (pr, pm) = (peak_times(&measured[..n]), peak_times(&model[..n]));
    // The noise level, from the residual's second differences (a smooth
    // misfit cancels in them; the median keeps the jumps out), so that
    // the structure's standard errors do not grow with the misfit itself.
    let sd = noise_sd(&r, whiten).unwrap_or(rms);
    // The model's rate of change, away from the jumps at reversals: a
    // record delayed by tau against the model leaves r ~ -tau dm/dt.
    let near_reversal = |i: usize| rev.iter().any(|&j| i + 3 >= j && i <= j + 3);
    let slope_m: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || i + 1 >= n || near_reversal(i) {
                0.0
            } else {
                (model[i + 1] - model[i - 1]) / (2.0 * dt)
            }
        })
        .collect();
    let mut half_cycles = Vec::new();
    for k in 0..bounds.len() - 1 {
        let (a, b) = (bounds[k], bounds[k + 1]);
        if b <= a {
            continue;
        }
        let amp = samples[a..b].iter().map(|s| s.u.abs()).fold(0.0, f64::max);
        let seg_rms = (r[a..b].iter().map(|v| v * v).sum::<f64>() / (b - a) as f64).sqrt();
        let moving = k + 1 < bounds.len() - 1 || samples[b - 1].phase.as_str() != "rest";
        let (p_rec, p_mod) = if k + 1 < pr.len() && moving {
            (Some(pr[k + 1] - pr[k]), Some(pm[k + 1] - pm[k]))
        } else {
            (None, None)
        };
        // Centred within the half-cycle, so that an offset enters neither
        // the gain nor the shift.
        let (mm, am) = centred_products(&model[a..b], &measured[a..b]);
        let (gg, rg) = centred_products(&slope_m[a..b], &r[a..b]);
        let (shift, shift_se) = if gg > 0.0 {
            (-rg / gg, sd / gg.sqrt())
        } else {
            (f64::NAN, f64::NAN)
        };
        half_cycles.push(HalfCycle {
            index: k,
            start: a as f64 * dt,
            end: b as f64 * dt,
            shift,
            shift_se,
            amplitude: amp,
            rms: seg_rms,
            period_record: p_rec,
            period_model: p_mod,
            gain: if mm > 0.0 { am / mm } else { f64::NAN },
            gain_se: if mm > 0.0 { sd / mm.sqrt() } else { f64::NAN },
        });
    }
    // Jumps at reversals.
    let jump = |a: &[f64], i: usize| -> Option<f64> {
        if i < 6 || i + 6 >= a.len() {
            return None;
        }
        Some(line_at(a, i + 2..=i + 6, i) - line_at(a, i - 6..=i - 2, i))
    };
    let jumps: Vec<Jump> = rev
        .iter()
        .filter_map(|&i| {
            let j = record_break(&measured[..n], i, sd);
            Some(Jump {
                t: i as f64 * dt,
                u: samples[i].u,
                record: jump(&measured[..n], j)?,
                model: jump(&model[..n], i)?,
            })
        })
        .collect();
    // Whiteness, of the residual whitened by the fitted noise model: colour
    // that the noise model explains is not a missing effect.
    let lag1_raw = autocorrelation(&r, 1);
    let w = self::whiten(&r, whiten);
    let (q, p) = ljung_box(&w);
    let lag1 = autocorrelation(&w, 1);
    // Spectrum (Hann window, periodogram).
    let size = n.next_power_of_two();
    let mut buf: Vec<rustfft::num_complex::Complex<f64>> = (0..size)
        .map(|i| {
            let v = if i < n {
                let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
                (r[i] - mean) * w
            } else {
                0.0
            };
            rustfft::num_complex::Complex::new(v, 0.0)
        })
        .collect();
    rustfft::FftPlanner::new()
        .plan_fft_forward(size)
        .process(&mut buf);
    let df = 1.0 / (size as f64 * dt);
    let power: Vec<f64> = buf[..size / 2].iter().map(|c| c.norm_sqr()).collect();
    let start = ((0.05 / df).ceil() as usize).max(1);
    let k_max = (start..power.len())
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
        .unwrap_or(start);
    let f_dom = k_max as f64 * df;
    let total: f64 = power[1..].iter().sum();
    let in_band = |k: usize| (k as f64 * df - f_dom).abs() <= 0.05 * f_dom.max(df);
    let (near, band) = (1..power.len())
        .filter(|&k| in_band(k))
        .fold((0.0, 0usize), |(p, n), k| (p + power[k], n + 1));
    let mut freqs = vec![base.f0];
    if spec.spring != crate::model::SpringKind::Linear {
        freqs.push(base.f1);
    }
    if spec.spring == crate::model::SpringKind::Trilinear {
        freqs.push(base.f2);
    }
    let can = freqs.iter().any(|&f| {
        [1.0, 2.0, 3.0]
            .iter()
            .any(|m| (f_dom - m * f).abs() <= 0.15 * m * f)
    });
    let spectrum = Spectrum {
        dominant_frequency_hz: f_dom,
        dominant_share: if total > 0.0 { near / total } else { 0.0 },
        white_share: band as f64 / (power.len() - 1).max(1) as f64,
        model_frequencies_hz: freqs,
        model_can_produce: can,
    };
    // Restoring-force residual map.
    let (umin, umax) = samples
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
            (a.min(s.u), b.max(s.u))
        });
    let (vmin, vmax) = samples
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
            (a.min(s.v), b.max(s.v))
        });
    let (nu, nv) = (8usize, 6usize);
    let edges = |lo: f64, hi: f64, k: usize| -> Vec<f64> {
        (0..=k)
            .map(|i| lo + (hi - lo) * i as f64 / k as f64)
            .collect()
    };
    let (ue, ve) = (edges(umin, umax, nu), edges(vmin, vmax, nv));
    let mut sum = vec![vec![0.0; nv]; nu];
    let mut cnt = vec![vec![0usize; nv]; nu];
    for (s, v) in samples.iter().zip(&r) {
        let iu = (((s.u - umin) / (umax - umin).max(1e-12)) * nu as f64)
            .floor()
            .clamp(0.0, (nu - 1) as f64) as usize;
        let iv = (((s.v - vmin) / (vmax - vmin).max(1e-12)) * nv as f64)
            .floor()
            .clamp(0.0, (nv - 1) as f64) as usize;
        sum[iu][iv] -= v;
        cnt[iu][iv] += 1;
    }
    let map_force: Vec<Vec<f64>> = sum
        .iter()
        .zip(&cnt)
        .map(|(s, c)| {
            s.iter()
                .zip(c)
                .map(|(s, c)| if *c > 0 { s / *c as f64 } else { f64::NAN })
                .collect()
        })
        .collect();
    let mut d = Diagnostics {
        noise_sd: sd,
        jump_sd: sd * 3.65f64.sqrt(),
        features: Vec::new(),
        e2: sse / energy,
        rms,
        mean,
        mean_at_rest,
        by_phase,
        half_cycles,
        jumps,
        ljung_box_q: q,
        ljung_box_p: p,
        lag1,
        lag1_raw,
        whitened_rho: whiten,
        dominant_frequency_hz: spectrum.dominant_frequency_hz,
        spectrum,
        map_u_edges: ue,
        map_v_edges: ve,
        map_force,
        verdict: String::new(),
    };
    d.features = features::all(&d, n);
    d.verdict = features::verdict(&d, &d.features);
    Ok(d)
}

/// The noise sd from the residual's second differences: their median
/// absolute value over `0.6745 sqrt(6 - 8 rho + 2 rho^2)` (the sd of a
/// second difference of AR(1) noise of unit variance is
/// `sqrt(6 - 8 rho + 2 rho^2)`).
fn noise_sd(r: &[f64], rho: Option<f64>) -> Option<f64> {
    let mut d2: Vec<f64> = r
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
        .collect();
    if d2.is_empty() {
        return None;
    }
    let mid = d2.len() / 2;
    let (_, med, _) = d2.select_nth_unstable_by(mid, f64::total_cmp);
    let rho = rho.unwrap_or(0.0);
    let s = *med / 0.6745 / (6.0 - 8.0 * rho + 2.0 * rho * rho).max(1e-6).sqrt();
    (s > 0.0).then_some(s)
}

/// `(sum (x - mean x)^2, sum (x - mean x)(y - mean y))`.
fn centred_products(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let xx = x.iter().map(|v| (v - mx).powi(2)).sum();
    let xy = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    (xx, xy)
}

/// Where the record's jump near the model's reversal `i` lies: the break
/// `c` (the jump between samples `c - 1` and `c`) within four samples of
/// `i` that best splits `a[i-10..=i+10]` into two lines, taken only when
/// it beats the break at `i` by more than nine noise variances (so that
/// noise alone rarely moves it, and a jump measured at `i` is not chosen
/// for its size). A model whose periods are off reverses samples away
/// from the record, and lines fitted around the model's reversal would
/// then straddle the record's jump and measure part of it.
fn record_break(a: &[f64], i: usize, sd: f64) -> usize {
    if i < 14 || i + 14 >= a.len() {
        return i;
    }
    let (lo, hi) = (i - 10, i + 10);
    let sse = |c: usize| line_sse(a, lo, c - 1) + line_sse(a, c, hi);
    let at_i = sse(i);
    let (best, s) = (i - 4..=i + 4)
        .map(|c| (c, sse(c)))
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .unwrap_or((i, at_i));
    if at_i - s > 9.0 * sd * sd {
        best
    } else {
        i
    }
}

/// Within this many sample intervals of its reversal (by its own velocity
/// and acceleration), a sample is taken to lie on it.
const ON_REVERSAL: f64 = 1e-6;

/// The reversals of `samples` (every `dt`): for each change of the sign of
/// the velocity, the first sample with the new sign, or the sample before
/// it where that one lies on the reversal; and each stop for good, its
/// first sample at rest. A restart from rest is no reversal.
///
/// A fit's reversals sit on sample instants to about 1e-13 s (the
/// likelihood's staircase steps there), where rounding in the engine
/// decides on which side the sample's velocity falls. Counted as the
/// first of the new sign either way, the sample no longer moves the
/// reversal, and with it the jumps' lines, by one sample: in session 18 it
/// moved the jump-size z of a calibration record across its gate.
fn reversals(samples: &[Motion], dt: f64) -> Vec<usize> {
    let on_reversal = |s: &Motion| s.v.abs() <= ON_REVERSAL * s.a.abs() * dt;
    let mut rev = Vec::new();
    // The velocity of the last moving sample since the last stop.
    let mut last: Option<f64> = None;
    for (i, s) in samples.iter().enumerate() {
        if s.v == 0.0 {
            if s.phase.as_str() == "rest" {
                if i > 0 && samples[i - 1].v != 0.0 {
                    rev.push(i);
                }
                last = None;
            }
            continue;
        }
        if last.is_some_and(|lv| lv * s.v < 0.0) {
            rev.push(if on_reversal(&samples[i - 1]) {
                i - 1
            } else {
                i
            });
        }
        last = Some(s.v);
    }
    rev
}

/// Residual sum of squares of the least-squares line through `a[lo..=hi]`.
fn line_sse(a: &[f64], lo: usize, hi: usize) -> f64 {
    let n = (hi + 1 - lo) as f64;
    let mx = (lo + hi) as f64 / 2.0;
    let my = a[lo..=hi].iter().sum::<f64>() / n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (k, y) in (lo..=hi).zip(&a[lo..=hi]) {
        let (dx, dy) = (k as f64 - mx, y - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if sxx > 0.0 {
        syy - sxy * sxy / sxx
    } else {
        syy
    }
}

/// The least-squares line through `a[range]`, evaluated half a sample
/// before sample `i` (where a reversal between samples `i - 1` and `i` is
/// placed).
fn line_at(a: &[f64], range: std::ops::RangeInclusive<usize>, i: usize) -> f64 {
    let x0 = i as f64 - 0.5;
    let pts: Vec<(f64, f64)> = range.map(|k| (k as f64 - x0, a[k])).collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let b = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    my - b * mx
}

/// `e_i - rho e_(i-1)` (the first scaled by `sqrt(1 - rho^2)`): the
/// residual of AR(1) noise made white; `e` itself without `rho`.
pub fn whiten(e: &[f64], rho: Option<f64>) -> Vec<f64> {
    match rho {
        Some(rho) => (0..e.len())
            .map(|i| {
                if i == 0 {
                    (1.0 - rho * rho).max(0.0).sqrt() * e[0]
                } else {
                    e[i] - rho * e[i - 1]
                }
            })
            .collect(),
        None => e.to_vec(),
    }
}

/// Lags of the Ljung-Box test ([`ljung_box`]; fewer on records shorter
/// than 80 samples).
pub const LJUNG_BOX_LAGS: usize = 20;

/// Ljung-Box statistic `Q` of `w` over `min(20, n / 4)` lags and its
/// p-value (chi-square with as many degrees of freedom).
///
/// ```
/// use hbis::criticism::residuals::ljung_box;
/// // A sign that alternates is as serially correlated as a series can be.
/// let w: Vec<f64> = (0..400).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// let (q, p) = ljung_box(&w);
/// assert!(q > 1000.0 && p < 1e-12);
/// ```
pub fn ljung_box(w: &[f64]) -> (f64, f64) {
    let n = w.len();
    let h = LJUNG_BOX_LAGS.min(n / 4);
    let q = n as f64
        * (n as f64 + 2.0)
        * (1..=h)
            .map(|k| autocorrelation(w, k).powi(2) / (n - k) as f64)
            .sum::<f64>();
    let p = ChiSquared::new(h as f64)
        .map(|c| 1.0 - c.cdf(q))
        .unwrap_or(f64::NAN);
    (q, p)
}

/// The lag-one coefficient of the noise in residual `r`, read from its
/// first differences, which a smooth misfit hardly reaches: at 200 Hz a
/// misfit at the structure's 0.5 Hz changes by 1.6 % of its size from one
/// sample to the next, while noise changes by its whole size. Steps and
/// spikes (a misfit at the reversals) are trimmed: differences beyond 4.5
/// robust standard deviations (from the median absolute deviation) and
/// the pairs they belong to are left out. For AR(1) noise it is the
/// coefficient; noise smoothed by an anti-alias filter reads above 1 (about
/// 1.9 for the calibration's sensor noise), white noise near 0.
///
/// # Formula
/// ```text
/// d_i = r_i - r_(i-1),   rho = 1 + 2 sum d_i d_(i-1) / sum d_i^2
/// ```
/// over the kept pairs, the differences about their median. For AR(1)
/// noise of coefficient `phi`, `corr(d_i, d_(i-1)) = -(1 - phi) / 2`, so
/// `rho = phi`; for white noise its standard deviation is about
/// `sqrt(2 / n)` (Bartlett's formula for the lag-one autocorrelation of
/// the differences, an MA(1) with coefficient -1: variance `0.5 / n`).
///
/// ```
/// use hbis::criticism::residuals::short_lag_rho;
/// // AR(1) noise with phi = 0.6 on a slow sine ten times its size.
/// let mut state = 1u64;
/// let mut unit = || {
///     // A small LCG and Box-Muller: the doctest needs no RNG crate.
///     let mut u = || {
///         state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///         ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
///     };
///     let (a, b) = (u(), u());
///     (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
/// };
/// let mut e = 0.0;
/// let r: Vec<f64> = (0..4000)
///     .map(|i| {
///         e = 0.6 * e + unit();
///         e + 10.0 * (0.0157 * i as f64).sin()
///     })
///     .collect();
/// // 0.655: about 0.02 from the sine's own changes, the rest scatter (sd
/// // near 0.03 on 4,000 samples).
/// assert!((short_lag_rho(&r) - 0.6).abs() < 0.1);
/// // A white residual with steps of twenty times the noise at twelve
/// // reversals: the smooth part and the steps leave rho near zero.
/// let w: Vec<f64> = (0..4000)
///     .map(|i| unit() + 10.0 * (0.0157 * i as f64).sin() + 20.0 * ((i / 333) % 2) as f64)
///     .collect();
/// assert!(short_lag_rho(&w).abs() < 0.1, "{}", short_lag_rho(&w));
/// ```
pub fn short_lag_rho(r: &[f64]) -> f64 {
    let d: Vec<f64> = r.windows(2).map(|w| w[1] - w[0]).collect();
    if d.len() < 3 {
        return 0.0;
    }
    let m = median(&mut d.clone());
    let limit = 4.5 * robust_scale(&d);
    let kept = |x: f64| (x - m).abs() <= limit;
    let (mut num, mut den) = (0.0, 0.0);
    for w in d.windows(2) {
        if kept(w[0]) && kept(w[1]) {
            num += (w[0] - m) * (w[1] - m);
            den += (w[1] - m).powi(2);
        }
    }
    if den > 0.0 {
        1.0 + 2.0 * num / den
    } else {
        0.0
    }
}

/// Lag-`k` autocorrelation of `x` about its mean.
pub fn autocorrelation(x: &[f64], k: usize) -> f64 {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let c0: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
    (k..n)
        .map(|i| (x[i] - mean) * (x[i - k] - mean))
        .sum::<f64>()
        / c0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::PhaseKind;

    /// A reversal at sample 50 of 100: velocity `c (50 - k) dt` before,
    /// `-2 c (k - 50) dt` after, with sample 50's velocity `v50`.
    fn motion(v50: f64) -> Vec<Motion> {
        let (c, dt) = (0.8, 0.005);
        (0..100)
            .map(|k| {
                let x = (k as f64 - 50.0) * dt;
                let (v, a) = match k.cmp(&50) {
                    std::cmp::Ordering::Less => (-c * x, -c),
                    std::cmp::Ordering::Equal => (v50, if v50 > 0.0 { -c } else { -2.0 * c }),
                    std::cmp::Ordering::Greater => (-2.0 * c * x, -2.0 * c),
                };
                Motion {
                    u: 0.01,
                    v,
                    a,
                    phase: PhaseKind::Elastic,
                }
            })
            .collect()
    }

    #[test]
    fn a_sample_on_its_reversal_is_the_first_after_it_on_either_side() {
        let dt = 0.005;
        for tiny in [1e-15, 1e-12, 0.0] {
            assert_eq!(reversals(&motion(tiny), dt), [50], "{tiny}");
            assert_eq!(reversals(&motion(-tiny), dt), [50], "{tiny}");
        }
        // A sample a thousandth of an interval before it is not on it.
        assert_eq!(reversals(&motion(0.8 * 1e-3 * dt), dt), [51]);
    }

    #[test]
    fn a_stop_is_a_reversal_and_the_restart_is_not() {
        let mut m = motion(-1e-3);
        for s in &mut m[60..70] {
            s.v = 0.0;
            s.phase = PhaseKind::Rest;
        }
        for s in &mut m[70..] {
            s.v = 0.01;
        }
        assert_eq!(reversals(&m, 0.005), [50, 60]);
    }
}
