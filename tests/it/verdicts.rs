//! Every branch of the residual verdict, each on a record built to trigger
//! it, asserting the sentence and its number. The model side is the
//! closed form of `trilinear+lcfm+viscous` at Test 5 of Table 8.1; the
//! record is the same model with one change (an offset, a stiffness that
//! degrades, more or less friction, friction that depends on the direction,
//! a superstructure mode, coloured noise), so the diagnosis sees one
//! structure at a time. Seeds fixed; thresholds are the features' own
//! (three standard errors and a physical size), not tuned here.

use hbis::criticism::diagnose;
use hbis::criticism::features::FeatureKind;
use hbis::criticism::Diagnostics;
use hbis::data::synthesize;
use hbis::model::{Model, Params};
use rand::{rngs::StdRng, RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

const DT: f64 = 0.005;
const N: usize = 2001;

fn base() -> (Model, Vec<f64>) {
    let m = Model::parse("trilinear+lcfm+viscous").unwrap();
    let theta = m
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
        .unwrap();
    (m, theta)
}

/// The clean acceleration of `spec` at Test 5 with `others` set.
fn clean(spec: &str, others: &[(&str, f64)], scale_uf0: f64) -> Vec<f64> {
    let m = Model::parse(spec).unwrap();
    let mut p = Params::table_8_1(5).unwrap();
    p.uf0 *= scale_uf0;
    let theta = m.theta_from_params(&p, others).unwrap();
    let mut rng = StdRng::seed_from_u64(0);
    synthesize(&m, &theta, DT, N, 0.0, &mut rng).unwrap().clean
}

/// White noise of 0.3 % of the model's peak (the effects are made small,
/// so that each shows alone).
fn noisy(mut a: Vec<f64>, seed: u64) -> Vec<f64> {
    let peak = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let normal = Normal::new(0.0, 0.003 * peak).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    for v in a.iter_mut() {
        *v += normal.sample(&mut rng);
    }
    a
}

fn diagnosis(record: &[f64], whiten: Option<f64>) -> Diagnostics {
    let (m, theta) = base();
    let model = clean("trilinear+lcfm+viscous", &[], 1.0);
    let p = m.core_params(&theta).unwrap();
    let motion = m.motion_grid(&theta, 0.0, DT, N).unwrap();
    diagnose(&m.spec(), &p, &motion, record, &model, DT, whiten).unwrap()
}

fn significant(d: &Diagnostics) -> Vec<FeatureKind> {
    d.features
        .iter()
        .filter(|f| f.significant)
        .map(|f| f.kind)
        .collect()
}

fn feature(d: &Diagnostics, k: FeatureKind) -> &hbis::criticism::features::Feature {
    d.features.iter().find(|f| f.kind == k).unwrap()
}

#[test]
fn no_missing_effect() {
    let d = diagnosis(&noisy(clean("trilinear+lcfm+viscous", &[], 1.0), 1), None);
    assert!(
        d.verdict.contains("consistent with white noise")
            && d.verdict.contains("no missing effect"),
        "{}",
        d.verdict
    );
    assert!(significant(&d).is_empty(), "{:?}", significant(&d));
}

#[test]
fn offset() {
    let rec: Vec<f64> = noisy(clean("trilinear+lcfm+viscous", &[], 1.0), 2)
        .iter()
        .map(|v| v + 0.02)
        .collect();
    let d = diagnosis(&rec, None);
    let f = feature(&d, FeatureKind::Offset);
    assert!((d.mean - 0.02).abs() < 0.002, "{}", d.mean);
    assert!(
        d.verdict.contains(&format!(
            "Its mean is {:+.2e} m/s^2 ({:.0} standard errors)",
            d.mean, f.z
        )) && d.verdict.contains("offset"),
        "{}",
        d.verdict
    );
    assert_eq!(significant(&d), vec![FeatureKind::Offset]);
}

#[test]
fn period_drift() {
    let rec = noisy(
        clean(
            "trilinear+lcfm+viscous+degradation",
            &[("kappa_k", 0.3)],
            1.0,
        ),
        3,
    );
    let d = diagnosis(&rec, None);
    let f = feature(&d, FeatureKind::PeriodDrift);
    assert!(f.significant && f.z > 3.0, "{f:?}");
    assert!(
        d.verdict.contains("period error drifts") && d.verdict.contains("softens"),
        "{}",
        d.verdict
    );
    assert!(d.verdict.contains(&format!("{:.1} standard errors", f.z)));
}

/// The model plus a staircase that steps by `scale(J)` times each of the
/// model's jumps `J` at its reversals: jumps larger or smaller by a known
/// factor, the motion otherwise the model's.
fn with_jumps(scale: &dyn Fn(f64) -> f64, seed: u64) -> Vec<f64> {
    let model = clean("trilinear+lcfm+viscous", &[], 1.0);
    let d = diagnosis(&model, None);
    let mut out = model.clone();
    for j in &d.jumps {
        // The reversal lies half a sample before sample i.
        let i = (j.t / DT).round() as usize;
        for v in out[i..].iter_mut() {
            *v += scale(j.model) * j.model;
        }
    }
    noisy(out, seed)
}

#[test]
fn jumps_larger_and_smaller() {
    for (scale, word) in [(0.5, "larger"), (-0.5, "smaller")] {
        let d = diagnosis(&with_jumps(&|_| scale, 4), None);
        let f = feature(&d, FeatureKind::JumpSize);
        assert!(f.significant, "{scale}: {f:?}");
        let pct = format!("{:.0} % {word} in the record", 100.0 * f.magnitude);
        assert!(d.verdict.contains(&pct), "{scale}: {} / {pct}", d.verdict);
        // Half the model's jumps added or taken away.
        assert!((f.magnitude - 0.5).abs() < 0.15, "{scale}: {f:?}");
        // The periods are the model's: the spring is not suspected.
        assert!(!feature(&d, FeatureKind::PeriodAmplitude).significant);
        assert!(!d.verdict.contains("stand in"), "{}", d.verdict);
    }
}

#[test]
fn jumps_by_direction() {
    // Jumps where sliding turns positive 60 % larger, the others as modelled.
    let d = diagnosis(&with_jumps(&|j| if j > 0.0 { 0.6 } else { 0.0 }, 5), None);
    let f = feature(&d, FeatureKind::JumpDirection);
    assert!(f.significant, "{f:?}");
    assert!((f.magnitude - 0.6).abs() < 0.2, "{f:?}");
    assert!(
        d.verdict.contains("differ by direction of sliding"),
        "{}",
        d.verdict
    );
}

#[test]
fn spectral_peak() {
    let rec: Vec<f64> = noisy(clean("trilinear+lcfm+viscous", &[], 1.0), 6)
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let t = i as f64 * DT;
            v + 0.15 * (2.0 * std::f64::consts::PI * 4.5 * t).sin() * (-t / 4.0).exp()
        })
        .collect();
    let d = diagnosis(&rec, None);
    assert!((d.spectrum.dominant_frequency_hz - 4.5).abs() < 0.05);
    assert!(
        d.verdict.contains(&format!(
            "unmodelled oscillation at {:.2} Hz",
            d.spectrum.dominant_frequency_hz
        )),
        "{}",
        d.verdict
    );
    assert!(significant(&d).contains(&FeatureKind::SpectralPeak));
}

#[test]
fn noise_colour_explained_by_ar1() {
    let model = clean("trilinear+lcfm+viscous", &[], 1.0);
    let peak = model.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut rng = StdRng::seed_from_u64(7);
    let normal = Normal::new(0.0, 0.01 * peak).unwrap();
    let mut e = 0.0;
    let rec: Vec<f64> = model
        .iter()
        .map(|v| {
            e = 0.6 * e + normal.sample(&mut rng);
            v + e
        })
        .collect();
    let _: f64 = rng.random();
    // Judged raw, the colour is blamed on the model; whitened by the
    // fitted AR(1) noise, it is not.
    let raw = diagnosis(&rec, None);
    assert!(
        raw.verdict.contains("is not white noise"),
        "{}",
        raw.verdict
    );
    let white = diagnosis(&rec, Some(0.6));
    assert!(
        white
            .verdict
            .contains("whitened by the fitted AR(1) noise (rho = 0.60")
            && white.verdict.contains("no missing effect"),
        "{}",
        white.verdict
    );
}

/// A wrong spring law with the right friction (`bilinear` fitted to a
/// trilinear record). The fit stands its friction slope in for the
/// missing third branch (rF0 about 3.8 times the truth's), so the fitted
/// friction really is larger than the record's, more so at large
/// amplitude, and the jumps must say exactly that: each record jump is
/// the truth's friction jump within noise, no direction dependence is
/// claimed, and the mismatch is said to grow with the amplitude. Measured
/// at the model's reversals (the record reversing two samples earlier at
/// 3.49 s) the record's lines straddled its jump: 8 % of the model's
/// there, and "0.91 against 0.58 by direction" (the earlier defect).
#[test]
fn a_wrong_spring_leaves_the_jumps_measured_at_the_records_reversals() {
    use hbis::criticism::{diagnosis_of, fit_model};
    use hbis::inference::{MapSettings, Noise};
    let truth = clean("trilinear+lcfm+viscous", &[], 1.0);
    let t = (0..N).map(|i| i as f64 * DT).collect();
    let data = hbis::data::Record::new(t, noisy(truth, 8))
        .unwrap()
        .aligned(None)
        .unwrap();
    let wrong = Model::parse("bilinear+lcfm+viscous").unwrap();
    let fit = fit_model(
        &wrong,
        &data,
        Noise::White,
        None,
        &MapSettings::default(),
        2,
    )
    .unwrap();
    let d = diagnosis_of(&wrong, &fit, &data).unwrap();
    // The jump in acceleration is 2 F_F / m = 2 w0^2 (uF0 + rF0 |u|).
    let jump = |p: &Params, u: f64| {
        2.0 * (2.0 * std::f64::consts::PI * p.f0).powi(2) * (p.uf0 + p.rf0 * u.abs())
    };
    let p_true = Params::table_8_1(5).unwrap();
    let p_fit = wrong.core_params(fit.model_theta(&wrong)).unwrap();
    assert!(p_fit.rf0 > 2.0 * p_true.rf0, "{p_fit:?}");
    assert!(d.jumps.len() >= 5, "{:?}", d.jumps);
    for j in &d.jumps {
        let (rec, model) = (jump(&p_true, j.u), jump(&p_fit, j.u));
        assert!(
            (j.record.abs() - rec).abs() < 3.5 * d.jump_sd,
            "record jump at {} s: {} against the truth's {rec} (sd {})",
            j.t,
            j.record,
            d.jump_sd
        );
        assert!((j.model.abs() - model).abs() < 0.1 * model, "{j:?}");
    }
    let direction = feature(&d, FeatureKind::JumpDirection);
    assert!(!direction.significant, "{direction:?}\n{}", d.verdict);
    let size = feature(&d, FeatureKind::JumpSize);
    assert!(
        size.significant && size.sentence.contains("smaller in the record"),
        "{size:?}"
    );
    assert!(
        size.sentence
            .contains("the mismatch grows with the amplitude"),
        "{}",
        size.sentence
    );
}

/// Periods off with the amplitude (a softer first post-yield branch, `f1`
/// 15 % lower) and jumps off (`uF0` halved): the verdict names both, then
/// suspects the spring before the friction, with both numbers.
#[test]
fn periods_and_jumps_off_together_put_the_spring_first() {
    let m = Model::parse("trilinear+lcfm+viscous").unwrap();
    let mut p = Params::table_8_1(5).unwrap();
    p.f1 *= 0.85;
    p.uf0 *= 0.5;
    let theta = m.theta_from_params(&p, &[]).unwrap();
    let mut rng = StdRng::seed_from_u64(0);
    let rec = synthesize(&m, &theta, DT, N, 0.0, &mut rng).unwrap().clean;
    let d = diagnosis(&noisy(rec, 9), None);
    let period = feature(&d, FeatureKind::PeriodAmplitude);
    let size = feature(&d, FeatureKind::JumpSize);
    assert!(period.significant && size.significant, "{}", d.verdict);
    let said = format!(
        "Both the half-cycle periods (mean error {:.1} % over all half-cycles) and the jumps at reversals ({:.0} % off) are off: a spring law that lacks a branch makes the fitted friction stand in for it",
        100.0 * period.magnitude,
        100.0 * size.magnitude
    );
    assert!(d.verdict.contains(&said), "{}", d.verdict);
}

/// White noise has no spectral peak: its largest periodogram ordinate
/// lies anywhere, and near the Nyquist frequency the band of ±5 % around
/// it holds a tenth of a white residual's power. The feature counts only
/// the share above what white noise puts in that band. (Before, a true
/// damper's refit on a calibration record, seed 804381413245, left a white
/// residual whose "peak" held 10.8 % of the power, and was refused for it.)
#[test]
fn white_noise_has_no_spectral_peak() {
    let model = clean("trilinear+lcfm+viscous", &[], 1.0);
    let mut peaks = Vec::new();
    for seed in 0..40 {
        let d = diagnosis(&noisy(model.clone(), 1000 + seed), None);
        let f = d
            .features
            .iter()
            .find(|f| f.kind == FeatureKind::SpectralPeak)
            .unwrap();
        peaks.push((
            seed,
            d.spectrum.dominant_frequency_hz,
            f.magnitude,
            f.significant,
        ));
    }
    eprintln!("{peaks:?}");
    let flagged: Vec<_> = peaks.iter().filter(|p| p.3).collect();
    assert!(flagged.is_empty(), "{flagged:?}");
}
