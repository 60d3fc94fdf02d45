//! The residual's structure, measured: each feature a number with its
//! standard error, significant or not, and the sentence that describes it
//! when it is. The verdict is made of these sentences, and a candidate
//! effect must shrink the feature it targets to be added.
//!
//! # Formula
//! ```text
//! offset          z = |mean r| / se,  se = rms/sqrt(n) sqrt((1 + r1)/(1 - r1))
//! shift           tau_k = -<r, dm/dt>_k / <dm/dt, dm/dt>_k  (record late by tau_k)
//! period drift    e_k = (tau_(k+1) - tau_k) / (c_(k+1) - c_k) = T_rec / T_mod - 1,
//!                 regressed on k (weighted): change = slope (K - 1)
//! decay rate      q_k = <a, m>_k / <m, m>_k (record on model in half-cycle k);
//!                 ln q_k regressed on k (weighted): change = slope (K - 1)
//! jump size       rho = sum J_rec J_mod / sum J_mod^2,  mismatch = rho - 1
//! jump direction  rho_+ - rho_- (jumps with J_mod > 0 against J_mod < 0)
//! spectral peak   share of the power within ±5 % of the largest ordinate's
//!                 frequency, less white noise's share of that band
//! ```
//! A feature is significant when it is large in physical terms (offset
//! aside) and at least three standard errors from zero.

use serde::Serialize;

use super::residuals::Diagnostics;
pub use crate::model::component::FeatureKind;

/// One measured feature.
#[derive(Debug, Clone, Serialize)]
pub struct Feature {
    /// What it measures.
    pub kind: FeatureKind,
    /// Its size (see the module's formulas; `Colour`: Ljung-Box `Q`).
    pub magnitude: f64,
    /// Magnitude over its standard error.
    pub z: f64,
    /// Whether it is large and clear enough to report.
    pub significant: bool,
    /// The sentence that reports it.
    pub sentence: String,
}

#[cfg(test)]
impl Feature {
    /// A feature with the given numbers and no sentence, for tests of the
    /// rules that read features.
    pub(crate) fn stub(kind: FeatureKind, magnitude: f64, z: f64, significant: bool) -> Self {
        Self {
            kind,
            magnitude,
            z,
            significant,
            sentence: String::new(),
        }
    }
}

/// Weighted least squares of `y` on `x` with known standard errors `se`:
/// slope and its standard error (at least three points).
pub fn weighted_slope(x: &[f64], y: &[f64], se: &[f64]) -> Option<(f64, f64)> {
    if x.len() < 3 {
        return None;
    }
    let w: Vec<f64> = se.iter().map(|s| 1.0 / (s * s)).collect();
    let sw: f64 = w.iter().sum();
    let mx = w.iter().zip(x).map(|(w, x)| w * x).sum::<f64>() / sw;
    let my = w.iter().zip(y).map(|(w, y)| w * y).sum::<f64>() / sw;
    let sxx: f64 = w.iter().zip(x).map(|(w, x)| w * (x - mx).powi(2)).sum();
    if sxx.is_nan() || sxx <= 0.0 {
        return None;
    }
    let b = w
        .iter()
        .zip(x.iter().zip(y))
        .map(|(w, (x, y))| w * (x - mx) * (y - my))
        .sum::<f64>()
        / sxx;
    Some((b, 1.0 / sxx.sqrt()))
}

/// The offset feature.
pub fn offset(d: &Diagnostics, n: usize) -> Feature {
    let r1 = d.lag1_raw.clamp(0.0, 0.99);
    let se = d.rms / (n as f64).sqrt() * ((1.0 + r1) / (1.0 - r1)).sqrt();
    let z = d.mean.abs() / se;
    Feature {
        kind: FeatureKind::Offset,
        magnitude: z,
        z,
        significant: z > 5.0,
        sentence: format!(
            "Its mean is {:+.2e} m/s^2 ({z:.0} standard errors){}: the accelerometer reads with an offset.",
            d.mean,
            d.mean_at_rest.map_or(String::new(), |m| format!(
                ", {m:+.2e} m/s^2 while the model is at rest"
            ))
        ),
    }
}

/// Period errors between consecutive half-cycles, from how late the
/// record runs against the model in each: `(index, amplitude,
/// T_rec / T_mod - 1, standard error)`, on swings a quarter of the largest
/// or more.
///
/// ```text
/// e_k = (tau_(k+1) - tau_k) / (c_(k+1) - c_k),  c_k the half-cycle's centre
/// ```
fn period_errors(d: &Diagnostics) -> Vec<(f64, f64, f64, f64)> {
    let a_max = d
        .half_cycles
        .iter()
        .map(|h| h.amplitude)
        .fold(0.0, f64::max);
    d.half_cycles
        .windows(2)
        .filter(|w| w[1].amplitude >= 0.1 * a_max && w[1].period_record.is_some())
        .filter(|w| w[0].shift_se > 0.0 && w[1].shift_se > 0.0)
        .map(|w| {
            let dc = 0.5 * (w[1].start + w[1].end - w[0].start - w[0].end);
            (
                w[1].index as f64,
                w[1].amplitude,
                (w[1].shift - w[0].shift) / dc,
                w[0].shift_se.hypot(w[1].shift_se) / dc,
            )
        })
        .collect()
}

/// Periods off by amplitude: errors of one sign beyond 2 % and three
/// standard errors on at least two swings.
pub fn period_amplitude(d: &Diagnostics) -> Feature {
    let e = period_errors(d);
    let off: Vec<&(f64, f64, f64, f64)> = e
        .iter()
        .filter(|p| p.2.abs() > 0.02 && p.2.abs() > 3.0 * p.3)
        .collect();
    let same = off.len() >= 2 && off.iter().all(|p| p.2.signum() == off[0].2.signum());
    let mean_err = if off.is_empty() {
        0.0
    } else {
        off.iter().map(|p| p.2).sum::<f64>() / off.len() as f64
    };
    let all = e.iter().map(|p| p.2.abs()).sum::<f64>() / e.len().max(1) as f64;
    let a_min = off.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    Feature {
        kind: FeatureKind::PeriodAmplitude,
        magnitude: all,
        z: f64::NAN,
        significant: same,
        sentence: format!(
            "The model's half-cycle period is {} than the record's by {:.1} % on average at amplitudes of {:.3} m and above: {}.",
            if mean_err > 0.0 { "shorter" } else { "longer" },
            100.0 * mean_err.abs(),
            a_min,
            if mean_err > 0.0 {
                "the structure is softer there than the model"
            } else {
                "the structure is stiffer there than the model"
            }
        ),
    }
}

/// Period error drifting across the test: its change over the timed swings
/// (weighted by their standard errors) beyond 1 % and three standard
/// errors.
pub fn period_drift(d: &Diagnostics) -> Feature {
    let e = period_errors(d);
    let x: Vec<f64> = e.iter().map(|p| p.0).collect();
    let y: Vec<f64> = e.iter().map(|p| p.2).collect();
    let se: Vec<f64> = e.iter().map(|p| p.3).collect();
    let fitted = weighted_slope(&x, &y, &se);
    let span = x.last().zip(x.first()).map_or(0.0, |(b, a)| b - a);
    let (change, z) = fitted.map_or((0.0, 0.0), |(b, se)| (b * span, b.abs() / se.max(1e-12)));
    let (first, last) = (
        y.first().copied().unwrap_or(0.0),
        y.last().copied().unwrap_or(0.0),
    );
    Feature {
        kind: FeatureKind::PeriodDrift,
        magnitude: change.abs(),
        z,
        significant: change.abs() > 0.01 && z > 3.0,
        sentence: format!(
            "The half-cycle period error drifts across the test, from {:+.1} % to {:+.1} % over half-cycles {:.0} to {:.0} (trend {:+.1} %, {z:.1} standard errors) while the amplitude falls from {:.3} m to {:.3} m: the structure {} as the test goes on, which the fitted stiffness does not reproduce (a stiffness that changes during the test, or one that depends on amplitude otherwise than the spring law says; one record does not tell them apart).",
            100.0 * first,
            100.0 * last,
            x.first().copied().unwrap_or(0.0),
            x.last().copied().unwrap_or(0.0),
            100.0 * change,
            e.first().map_or(0.0, |p| p.1),
            e.last().map_or(0.0, |p| p.1),
            if change > 0.0 { "softens" } else { "stiffens" }
        ),
    }
}

/// Swings decaying at another rate than the model's.
pub fn decay_rate(d: &Diagnostics) -> Feature {
    let a_max = d
        .half_cycles
        .iter()
        .map(|h| h.amplitude)
        .fold(0.0, f64::max);
    let kept: Vec<_> = d
        .half_cycles
        .iter()
        .filter(|h| h.amplitude >= 0.1 * a_max && h.gain > 0.0 && h.gain_se > 0.0)
        .collect();
    let x: Vec<f64> = kept.iter().map(|h| h.index as f64).collect();
    let y: Vec<f64> = kept.iter().map(|h| h.gain.ln()).collect();
    let se: Vec<f64> = kept.iter().map(|h| h.gain_se / h.gain).collect();
    let fitted = weighted_slope(&x, &y, &se);
    let span = x.last().zip(x.first()).map_or(0.0, |(b, a)| b - a);
    let (change, z) = fitted.map_or((0.0, 0.0), |(b, se)| (b * span, b.abs() / se.max(1e-12)));
    Feature {
        kind: FeatureKind::DecayRate,
        magnitude: change.abs(),
        z,
        significant: change.abs() > 0.05 && z > 3.0,
        sentence: format!(
            "The record's swings decay {} than the model's: the record's size relative to the model's changes by {:+.1} % from half-cycle {:.0} to {:.0} ({z:.1} standard errors): the model {} energy than the structure.",
            if change < 0.0 { "faster" } else { "slower" },
            100.0 * (change.exp() - 1.0),
            x.first().copied().unwrap_or(0.0),
            x.last().copied().unwrap_or(0.0),
            if change < 0.0 { "dissipates less" } else { "dissipates more" }
        ),
    }
}

/// The record's jumps regressed on the model's over `js`: ratio and its
/// standard error (`sd_jump` the noise sd of one jump).
fn jump_ratio(js: &[(f64, f64)], sd_jump: f64) -> Option<(f64, f64)> {
    let mm: f64 = js.iter().map(|j| j.1 * j.1).sum();
    if js.len() < 2 || mm <= 0.0 {
        return None;
    }
    let ratio = js.iter().map(|j| j.0 * j.1).sum::<f64>() / mm;
    Some((ratio, sd_jump / mm.sqrt()))
}

/// Jumps larger or smaller overall: beyond 10 % and three standard errors.
pub fn jump_size(d: &Diagnostics) -> Feature {
    let js: Vec<(f64, f64)> = d.jumps.iter().map(|j| (j.record, j.model)).collect();
    let (ratio, se) = jump_ratio(&js, d.jump_sd).unwrap_or((1.0, f64::INFINITY));
    let z = (ratio - 1.0).abs() / se;
    let word = if ratio > 1.0 { "larger" } else { "smaller" };
    Feature {
        kind: FeatureKind::JumpSize,
        magnitude: (ratio - 1.0).abs(),
        z,
        significant: (ratio - 1.0).abs() > 0.1 && z > 3.0,
        sentence: format!(
            "The acceleration jumps at reversals are {:.0} % {word} in the record than in the model ({z:.0} standard errors; jumps measured between lines fitted on each side of each reversal): the friction force at reversals is {word} than modelled{}.",
            100.0 * (ratio - 1.0).abs(),
            amplitude_trend(d, ratio)
        ),
    }
}

/// Jumps that differ by direction of sliding: beyond 10 % and three
/// standard errors.
pub fn jump_direction(d: &Diagnostics) -> Feature {
    let side = |positive: bool| -> Option<(f64, f64)> {
        let js: Vec<(f64, f64)> = d
            .jumps
            .iter()
            .filter(|j| (j.model > 0.0) == positive)
            .map(|j| (j.record, j.model))
            .collect();
        jump_ratio(&js, d.jump_sd)
    };
    let (diff, z, pos, neg) = match (side(true), side(false)) {
        (Some((p, sp)), Some((n, sn))) => (p - n, (p - n).abs() / sp.hypot(sn), p, n),
        _ => (0.0, 0.0, 1.0, 1.0),
    };
    Feature {
        kind: FeatureKind::JumpDirection,
        magnitude: diff.abs(),
        z,
        significant: diff.abs() > 0.1 && z > 3.0,
        sentence: format!(
            "The jumps differ by direction of sliding: record over model {pos:.2} when sliding turns positive, {neg:.2} when it turns negative ({z:.0} standard errors): the friction force depends on the direction of sliding."
        ),
    }
}

/// A residual peak the model cannot produce, with a tenth of the power.
pub fn spectral_peak(d: &Diagnostics) -> Feature {
    let s = &d.spectrum;
    // Above white noise's share of the band: near the Nyquist frequency a
    // white residual's largest ordinate brings a tenth of the power with
    // its band (4 of 40 white residuals were flagged before).
    let excess = (s.dominant_share - s.white_share).max(0.0);
    let magnitude = if s.model_can_produce { 0.0 } else { excess };
    Feature {
        kind: FeatureKind::SpectralPeak,
        magnitude,
        z: f64::NAN,
        significant: !s.model_can_produce && excess > 0.1,
        sentence: format!(
            "The residual oscillates at {:.2} Hz ({:.0} % of its power, {:.0} % for white noise), which the model cannot produce (its frequencies are {} Hz): an unmodelled oscillation at {:.2} Hz, such as a flexible superstructure mode ringing after the friction jumps.",
            s.dominant_frequency_hz,
            100.0 * s.dominant_share,
            100.0 * s.white_share,
            s.model_frequencies_hz
                .iter()
                .map(|f| format!("{f:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            s.dominant_frequency_hz
        ),
    }
}

/// Serial correlation (of the whitened residual).
pub fn colour(d: &Diagnostics) -> Feature {
    Feature {
        kind: FeatureKind::Colour,
        magnitude: d.ljung_box_q,
        z: f64::NAN,
        significant: !(d.ljung_box_p > 0.01 && d.lag1.abs() < 0.2),
        sentence: String::new(),
    }
}

/// Whether the jump mismatch (record over model `ratio` overall) grows or
/// shrinks in size with the amplitude. The signed difference record minus
/// model falls with the amplitude both when jumps too small grow more so
/// and when jumps too large shrink towards the model's, so its correlation
/// is read against the mismatch's own sign.
fn amplitude_trend(d: &Diagnostics, ratio: f64) -> String {
    let x: Vec<f64> = d.jumps.iter().map(|j| j.u.abs()).collect();
    let y: Vec<f64> = d
        .jumps
        .iter()
        .map(|j| (j.record - j.model) * j.model.signum())
        .collect();
    let n = x.len() as f64;
    if x.len() < 2 {
        return String::new();
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let syy: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
    if sxx <= 0.0 || syy <= 0.0 {
        return String::new();
    }
    let r = sxy / (sxx * syy).sqrt();
    if r.abs() > 0.7 {
        let grows = (r > 0.0) == (ratio > 1.0);
        format!(
            ", and the mismatch {} with the amplitude (correlation of the difference with the amplitude {r:+.2})",
            if grows { "grows" } else { "shrinks" }
        )
    } else {
        String::new()
    }
}

/// Every feature of a diagnosis (`n` samples).
pub fn all(d: &Diagnostics, n: usize) -> Vec<Feature> {
    vec![
        colour(d),
        offset(d, n),
        period_amplitude(d),
        period_drift(d),
        decay_rate(d),
        jump_size(d),
        jump_direction(d),
        spectral_peak(d),
    ]
}

/// When the periods are off with the amplitude and the jumps are off too,
/// the spring law is suspect before the friction: a fit whose spring lacks
/// a branch bends its friction to make up for it (fitted to a trilinear
/// Test 5 record, `bilinear+lcfm+viscous` takes `rF0` 3.8 times the
/// truth's), so the jumps then compare the record with a friction that is
/// itself standing in.
fn spring_behind_friction(structured: &[&Feature]) -> Option<String> {
    let of = |k: FeatureKind| structured.iter().find(|f| f.kind == k);
    let (period, jump) = (
        of(FeatureKind::PeriodAmplitude)?,
        of(FeatureKind::JumpSize)?,
    );
    Some(format!(
        "Both the half-cycle periods (mean error {:.1} % over all half-cycles) and the jumps at reversals ({:.0} % off) are off: a spring law that lacks a branch makes the fitted friction stand in for it, so the jump mismatch may be the spring's; try the spring's candidates before the friction's.",
        100.0 * period.magnitude,
        100.0 * jump.magnitude
    ))
}

/// The verdict: whiteness, then each significant feature's sentence, then
/// where the residual is largest.
pub fn verdict(d: &Diagnostics, features: &[Feature]) -> String {
    let whitened = match d.whitened_rho {
        Some(rho) => format!(
            ", whitened by the fitted AR(1) noise (rho = {rho:.2}; lag-one correlation {:.2} before),",
            d.lag1_raw
        ),
        None => String::new(),
    };
    let white = !features
        .iter()
        .any(|f| f.kind == FeatureKind::Colour && f.significant);
    let structured: Vec<&Feature> = features
        .iter()
        .filter(|f| f.significant && f.kind != FeatureKind::Colour)
        .collect();
    let mut lines = Vec::new();
    if d.e2.is_nan() || d.e2 > crate::criticism::sanity::EXPLAINS_NOTHING_E2 {
        lines.push(format!(
            "The model explains only {:.1} % of the record's energy (e2 = {:.4}): the residual is most of the record, so whether it looks white (Ljung-Box p = {:.2}) says nothing about missing effects; the record may be noise only, in other units, or the model far from it.",
            100.0 * (1.0 - d.e2).max(0.0),
            d.e2,
            d.ljung_box_p
        ));
        return lines.join(" ");
    }
    if white && structured.is_empty() {
        lines.push(format!(
            "The residual (RMS {:.2e} m/s^2, e2 = {:.5}){whitened} is consistent with white noise (Ljung-Box p = {:.2}): the record shows no missing effect.",
            d.rms, d.e2, d.ljung_box_p
        ));
        return lines.join(" ");
    }
    if white {
        lines.push(format!(
            "The residual (RMS {:.2e} m/s^2, e2 = {:.5}){whitened} fluctuates like white noise (Ljung-Box p = {:.2}) but has structure.",
            d.rms, d.e2, d.ljung_box_p
        ));
    } else {
        lines.push(format!(
            "The residual (RMS {:.2e} m/s^2, e2 = {:.5}){whitened} is not white noise (Ljung-Box p = {:.1e}, lag-one correlation {:.2}): the model misses something.",
            d.rms, d.e2, d.ljung_box_p, d.lag1
        ));
    }
    lines.extend(structured.iter().map(|f| f.sentence.clone()));
    lines.extend(spring_behind_friction(&structured));
    if let Some(worst) = d
        .by_phase
        .iter()
        .filter(|g| g.samples >= 10)
        .max_by(|a, b| a.rms.total_cmp(&b.rms))
    {
        lines.push(format!(
            "The residual is largest in the {} phase (RMS {:.2e} m/s^2).",
            worst.group, worst.rms
        ));
    }
    lines.join(" ")
}
