//! `predict` end to end: a prediction's job (the model, its draws, the
//! ground motions), its run and its files (`predict.json`, `draws.csv`,
//! `band.csv`, `response.png`, `peak-displacement.png`, and with a
//! fragility curve `fragility.png`).
//!
//! `hbis predict` and the demo write through [`write_prediction`].

use std::path::PathBuf;

use serde::Serialize;
use thiserror::Error;

use crate::data::ground_motion::GroundMotion;
use crate::inference::proportion::Clustered;
use crate::model::{ForwardModel, Model};
use crate::report::outdir::{OutDir, OutError};
use crate::study::predict::{
    fragility, fragility_point, predict_suite, Draw, Extrapolation, FragilityPoint, PredictError,
    PredictOptions, Prediction, Summary,
};

/// Why a prediction could not be run or written.
#[derive(Debug, Error)]
pub enum PredictionError {
    /// The prediction.
    #[error(transparent)]
    Predict(#[from] PredictError),
    /// A file of the output folder.
    #[error(transparent)]
    Out(#[from] OutError),
    /// Serialising the report.
    #[error("serialising the report")]
    Json(#[from] serde_json::Error),
    /// A figure.
    #[cfg(feature = "figures")]
    #[error(transparent)]
    Figure(#[from] crate::report::figures::FigureError),
}

/// `predict.json` (keys documented in docs/cli.md).
#[derive(Debug, Serialize)]
pub struct PredictReport<'a> {
    /// The version of hbis that wrote it.
    pub hbis_version: &'a str,
    /// Always `"predict"`.
    pub command: &'a str,
    /// The model simulated.
    pub model: String,
    /// The seed.
    pub seed: u64,
    /// Where the draws came from.
    pub source: DrawSource,
    /// The ground motion, when there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionInfo>,
    /// Every ground motion of the suite (one for a single motion).
    pub motions: Vec<MotionInfo>,
    /// Free vibration simulated after the motion (s).
    pub tail: f64,
    /// Displacement capacity (m), if given.
    pub capacity: Option<f64>,
    /// Number of posterior draws simulated.
    pub draws: usize,
    /// Number of (draw, motion) pairs simulated.
    pub pairs: usize,
    /// The design quantities over the pairs.
    pub summary: &'a Summary,
    /// Share of pairs whose peak displacement exceeds the capacity.
    pub p_exceed_capacity: Option<f64>,
    /// That share with its 95 % interval (the motions as clusters).
    pub p_exceed_ci: Option<Clustered>,
    /// The fragility curve, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fragility: Option<&'a [FragilityPoint]>,
    /// How far the motion takes the isolator beyond the release test.
    pub extrapolation: &'a Extrapolation,
    /// What may make the prediction wrong.
    pub warnings: &'a [String],
}

/// Where a prediction's draws came from (`source` in predict.json).
#[derive(Debug, Serialize)]
pub struct DrawSource {
    /// The fit's folder, for a fit's posterior draws.
    pub fit: Option<String>,
    /// The parameter file, for one parameter set.
    pub params: Option<String>,
    /// The fit's seed, as its fit.json records it.
    pub fit_seed: Option<u64>,
}

/// The ground motion (`motion` in predict.json).
#[derive(Debug, Serialize)]
pub struct MotionInfo {
    /// The motion's file or generator.
    pub source: String,
    /// Its sampling step (s).
    pub dt: f64,
    /// Its samples.
    pub samples: usize,
    /// Its duration (s).
    pub duration: f64,
    /// Its peak ground acceleration (m/s^2), after scaling.
    pub pga: f64,
    /// The factor the record was scaled by.
    pub scale: f64,
}

/// One prediction to run and write.
pub struct PredictJob {
    /// The model simulated.
    pub model: Model,
    /// Its parameter sets (a fit's draws, or one).
    pub draws: Vec<Draw>,
    /// The fit's folder, if the draws are a fit's.
    pub fit: Option<PathBuf>,
    /// The fit's seed.
    pub fit_seed: Option<u64>,
    /// The parameter file, for one parameter set.
    pub params: Option<PathBuf>,
    /// The ground motions (one, or a suite), each at the level of the
    /// summary.
    pub motions: Vec<GroundMotion>,
    /// The factor the motions were scaled by.
    pub scale: f64,
    /// Peak ground accelerations (m/s^2) of a fragility curve of the
    /// capacity (empty: none).
    pub fragility_pgas: Vec<f64>,
    /// The seed written into predict.json.
    pub seed: u64,
    /// Tail, capacity, band resolution.
    pub opts: PredictOptions,
}

/// A prediction and its fragility curve.
#[derive(Debug, Clone)]
pub struct PredictOutcome {
    /// The prediction at the motions' own level.
    pub prediction: Prediction,
    /// The fragility curve, when asked for.
    pub fragility: Option<Vec<FragilityPoint>>,
}

/// Runs `job`: the prediction, and the fragility curve when
/// `fragility_pgas` is not empty (it needs the capacity).
pub fn run_prediction(job: &PredictJob) -> Result<PredictOutcome, PredictError> {
    let suite: Vec<(f64, &[f64])> = job
        .motions
        .iter()
        .map(|m| (m.dt, m.ag.as_slice()))
        .collect();
    let prediction = predict_suite(&job.model, &job.draws, &suite, &job.opts)?;
    let fragility = match (job.fragility_pgas.is_empty(), job.opts.capacity) {
        (true, _) => None,
        (false, None) => {
            return Err(PredictError::Invalid(
                "a fragility curve needs the capacity".into(),
            ))
        }
        (false, Some(c)) => {
            // The prediction itself is the curve's first point when its
            // motions are already at that level (as `hbis predict --pga`
            // makes them): one suite fewer to simulate.
            let pgas = &job.fragility_pgas;
            let reused = at_level(&job.motions, pgas[0])
                .then(|| fragility_point(pgas[0], &prediction))
                .transpose()?;
            let rest = &pgas[usize::from(reused.is_some())..];
            let mut points: Vec<FragilityPoint> = reused.into_iter().collect();
            points.extend(fragility(
                &job.model,
                &job.draws,
                &job.motions,
                rest,
                c,
                &job.opts,
            )?);
            Some(points)
        }
    };
    Ok(PredictOutcome {
        prediction,
        fragility,
    })
}

/// Whether every motion's peak ground acceleration is `pga` (to round-off).
fn at_level(motions: &[GroundMotion], pga: f64) -> bool {
    motions
        .iter()
        .all(|m| (m.pga() - pga).abs() <= 1e-12 * pga.abs())
}

fn motion_info(m: &GroundMotion, scale: f64) -> MotionInfo {
    MotionInfo {
        source: m.source.clone(),
        dt: m.dt,
        samples: m.ag.len(),
        duration: m.duration(),
        pga: m.pga(),
        scale,
    }
}

/// Runs `job` and writes its outputs into `dir`; returns the prediction
/// and `predict.json`'s text.
pub fn write_prediction(
    dir: &mut OutDir,
    job: &PredictJob,
) -> Result<(PredictOutcome, String), PredictionError> {
    let (model, draws) = (&job.model, &job.draws);
    let out = run_prediction(job)?;
    let p = &out.prediction;
    let motions: Vec<MotionInfo> = job
        .motions
        .iter()
        .map(|m| motion_info(m, job.scale))
        .collect();
    let report = PredictReport {
        hbis_version: env!("CARGO_PKG_VERSION"),
        command: "predict",
        model: model.name(),
        seed: job.seed,
        source: DrawSource {
            fit: job.fit.as_ref().map(|p| p.display().to_string()),
            params: job.params.as_ref().map(|p| p.display().to_string()),
            fit_seed: job.fit_seed,
        },
        motion: match job.motions.as_slice() {
            [m] => Some(motion_info(m, job.scale)),
            _ => None,
        },
        motions,
        tail: job.opts.tail,
        capacity: job.opts.capacity,
        draws: draws.len(),
        pairs: p.pairs.len(),
        summary: &p.summary,
        p_exceed_capacity: p.p_exceed_capacity,
        p_exceed_ci: p.exceedance,
        fragility: out.fragility.as_deref(),
        extrapolation: &p.extrapolation,
        warnings: &p.warnings,
    };
    let json = serde_json::to_string_pretty(&report)? + "\n";
    let capacity = job.opts.capacity;
    dir.write("draws.csv", draws_csv(model, draws, p, capacity).as_bytes())?;
    if let Some(b) = &p.band {
        let mut s = String::from("t,q05,q50,q95\n");
        for i in 0..b.t.len() {
            s += &format!("{},{},{},{}\n", b.t[i], b.q05[i], b.q50[i], b.q95[i]);
        }
        dir.write("band.csv", s.as_bytes())?;
    }
    figures(dir, job, &out)?;
    dir.write("predict.json", json.as_bytes())?;
    Ok((out, json))
}

fn draws_csv(model: &Model, draws: &[Draw], p: &Prediction, capacity: Option<f64>) -> String {
    let names = model.param_names();
    let mut s = String::from("draw,chain,row,");
    s += &names.join(",");
    s += ",m,peak_displacement,residual_displacement,peak_base_shear,peak_total_acceleration,peak_base_shear_kN,exceeds_capacity,motion\n";
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for (pair, o) in p.pairs.iter().zip(&p.outcomes) {
        let d = &draws[pair.draw];
        let (chain, row) = d.origin.map_or((String::new(), String::new()), |(c, r)| {
            (c.to_string(), r.to_string())
        });
        let theta: Vec<String> = d.theta.iter().map(f64::to_string).collect();
        let k = &o.peaks;
        s += &format!(
            "{},{chain},{row},{},{},{},{},{},{},{},{},{}\n",
            pair.draw + 1,
            theta.join(","),
            opt(d.mass),
            k.peak_displacement,
            k.residual_displacement,
            k.peak_base_shear,
            k.peak_total_acceleration,
            opt(o.peak_base_shear_kn),
            capacity.map_or(String::new(), |c| (k.peak_displacement > c).to_string()),
            pair.motion + 1,
        );
    }
    s
}

#[cfg(feature = "figures")]
fn figures(
    dir: &mut OutDir,
    job: &PredictJob,
    out: &PredictOutcome,
) -> Result<(), PredictionError> {
    use crate::report::figures::{self, ResponseFigure};
    let p = &out.prediction;
    let capacity = job.opts.capacity;
    if let Some(b) = &p.band {
        let motions: Vec<(f64, &[f64])> = job
            .motions
            .iter()
            .map(|m| (m.dt, m.ag.as_slice()))
            .collect();
        let u0 = job.model.param_names().iter().position(|n| n == "u0");
        let u0s: Vec<f64> = u0
            .map(|k| job.draws.iter().map(|d| d.theta[k].abs()).collect())
            .unwrap_or_default();
        let fig = ResponseFigure {
            band: b,
            motions: &motions,
            capacity,
            release: (!u0s.is_empty())
                .then(|| crate::inference::summary::ParamSummary::from_draws(&u0s).q50),
            share_beyond_release: p.extrapolation.share_beyond_release,
            draws: job.draws.len(),
        };
        dir.write_with("response.png", |tmp| {
            figures::response_band_figure(tmp, &fig)
        })?;
    }
    let peaks: Vec<f64> = p
        .outcomes
        .iter()
        .map(|o| o.peaks.peak_displacement)
        .collect();
    dir.write_with("peak-displacement.png", |tmp| {
        figures::peak_displacement_figure(tmp, &peaks, capacity, p.p_exceed_capacity)
    })?;
    if let (Some(f), Some(c)) = (&out.fragility, capacity) {
        dir.write_with("fragility.png", |tmp| {
            figures::fragility_figure(tmp, f, c, job.motions.len())
        })?;
    }
    Ok(())
}

#[cfg(not(feature = "figures"))]
fn figures(_: &mut OutDir, _: &PredictJob, _: &PredictOutcome) -> Result<(), PredictionError> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::ground_motion::KanaiTajimi;
    use crate::model::{Params, Registry};

    fn job(scale: f64) -> PredictJob {
        let model = Registry::builtin().parse("bilinear+coulomb").unwrap();
        let p = Params::table_8_1(5).unwrap();
        let draws = (0..4)
            .map(|k| {
                let mut q = p;
                q.u0 *= 0.9 + 0.05 * k as f64;
                Draw::new(model.theta_from_params(&q, &[]).unwrap())
            })
            .collect();
        let kt = KanaiTajimi {
            pga: 2.0,
            duration: 15.0,
            dt: 0.01,
            ..Default::default()
        };
        let motions = kt
            .suite(3, 5)
            .unwrap()
            .into_iter()
            .map(|m| m.scaled(scale).unwrap())
            .collect();
        PredictJob {
            model,
            draws,
            fit: None,
            fit_seed: None,
            params: None,
            motions,
            scale,
            fragility_pgas: vec![2.0, 4.0],
            seed: 5,
            opts: PredictOptions {
                capacity: Some(0.06),
                ..Default::default()
            },
        }
    }

    /// With its motions at the curve's first level the prediction is the
    /// first point (not simulated again); otherwise that level is simulated.
    /// Either way the curve is the one [`fragility`] computes alone.
    #[test]
    fn the_fragility_curve_reuses_the_prediction_at_its_own_level() {
        for scale in [1.0, 1.5] {
            let job = job(scale);
            let out = run_prediction(&job).unwrap();
            let curve = out.fragility.unwrap();
            let alone = fragility(
                &job.model,
                &job.draws,
                &job.motions,
                &job.fragility_pgas,
                0.06,
                &job.opts,
            )
            .unwrap();
            assert_eq!(curve.len(), 2);
            for (a, b) in curve.iter().zip(&alone) {
                assert_eq!(a.pga_g, b.pga_g);
                assert_eq!(
                    (a.p_exceed, a.ci_low, a.ci_high),
                    (b.p_exceed, b.ci_low, b.ci_high)
                );
                assert_eq!(a.pairs, b.pairs);
                let (x, y) = (&a.peak_displacement, &b.peak_displacement);
                assert!(
                    (x.mean - y.mean).abs() <= 1e-12 * y.mean.abs(),
                    "{} {}",
                    x.mean,
                    y.mean
                );
            }
            let first = (curve[0].p_exceed, out.prediction.p_exceed_capacity.unwrap());
            if scale == 1.0 {
                assert!(at_level(&job.motions, 2.0));
                assert_eq!(first.0, first.1);
            } else {
                assert!(!at_level(&job.motions, 2.0));
            }
        }
    }
}
