//! `predict` end to end: a prediction's job (the model, its draws, the
//! ground motion), its run and its files (`predict.json`, `draws.csv`,
//! `band.csv`, `response.png`, `peak-displacement.png`).
//!
//! `hbis predict` and the demo write through [`write_prediction`].

use std::path::PathBuf;

use serde::Serialize;
use thiserror::Error;

use crate::data::ground_motion::GroundMotion;
use crate::model::{ForwardModel, Model};
use crate::report::outdir::{OutDir, OutError};
use crate::study::predict::{
    predict, Draw, Extrapolation, PredictError, PredictOptions, Prediction, Summary,
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
    /// The ground motion.
    pub motion: MotionInfo,
    /// Free vibration simulated after the motion (s).
    pub tail: f64,
    /// Displacement capacity (m), if given.
    pub capacity: Option<f64>,
    /// Number of draws simulated.
    pub draws: usize,
    /// The design quantities over the draws.
    pub summary: &'a Summary,
    /// Share of draws whose peak displacement exceeds the capacity.
    pub p_exceed_capacity: Option<f64>,
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
    /// The ground motion.
    pub motion: GroundMotion,
    /// The factor the motion was scaled by.
    pub scale: f64,
    /// The seed written into predict.json.
    pub seed: u64,
    /// Tail, capacity, band resolution.
    pub opts: PredictOptions,
}

/// Runs `job` and writes its outputs into `dir`; returns the prediction
/// and `predict.json`'s text.
pub fn write_prediction(
    dir: &mut OutDir,
    job: &PredictJob,
) -> Result<(Prediction, String), PredictionError> {
    let (model, draws, motion) = (&job.model, &job.draws, &job.motion);
    let p = predict(model, draws, motion.dt, &motion.ag, &job.opts)?;
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
        motion: MotionInfo {
            source: motion.source.clone(),
            dt: motion.dt,
            samples: motion.ag.len(),
            duration: motion.duration(),
            pga: motion.pga(),
            scale: job.scale,
        },
        tail: job.opts.tail,
        capacity: job.opts.capacity,
        draws: draws.len(),
        summary: &p.summary,
        p_exceed_capacity: p.p_exceed_capacity,
        extrapolation: &p.extrapolation,
        warnings: &p.warnings,
    };
    let json = serde_json::to_string_pretty(&report)? + "\n";
    let capacity = job.opts.capacity;
    dir.write(
        "draws.csv",
        draws_csv(model, draws, &p, capacity).as_bytes(),
    )?;
    if let Some(b) = &p.band {
        let mut s = String::from("t,q05,q50,q95\n");
        for i in 0..b.t.len() {
            s += &format!("{},{},{},{}\n", b.t[i], b.q05[i], b.q50[i], b.q95[i]);
        }
        dir.write("band.csv", s.as_bytes())?;
    }
    figures(dir, &p, motion, capacity)?;
    dir.write("predict.json", json.as_bytes())?;
    Ok((p, json))
}

fn draws_csv(model: &Model, draws: &[Draw], p: &Prediction, capacity: Option<f64>) -> String {
    let names = model.param_names();
    let mut s = String::from("draw,chain,row,");
    s += &names.join(",");
    s += ",m,peak_displacement,residual_displacement,peak_base_shear,peak_total_acceleration,peak_base_shear_kN,exceeds_capacity\n";
    let opt = |x: Option<f64>| x.map(|v| v.to_string()).unwrap_or_default();
    for (i, (d, o)) in draws.iter().zip(&p.outcomes).enumerate() {
        let (chain, row) = d.origin.map_or((String::new(), String::new()), |(c, r)| {
            (c.to_string(), r.to_string())
        });
        let theta: Vec<String> = d.theta.iter().map(f64::to_string).collect();
        let k = &o.peaks;
        s += &format!(
            "{},{chain},{row},{},{},{},{},{},{},{},{}\n",
            i + 1,
            theta.join(","),
            opt(d.mass),
            k.peak_displacement,
            k.residual_displacement,
            k.peak_base_shear,
            k.peak_total_acceleration,
            opt(o.peak_base_shear_kn),
            capacity.map_or(String::new(), |c| (k.peak_displacement > c).to_string()),
        );
    }
    s
}

#[cfg(feature = "figures")]
fn figures(
    dir: &mut OutDir,
    p: &Prediction,
    motion: &GroundMotion,
    capacity: Option<f64>,
) -> Result<(), PredictionError> {
    use crate::report::figures;
    if let Some(b) = &p.band {
        dir.write_with("response.png", |tmp| {
            figures::response_band_figure(tmp, b, (motion.dt, &motion.ag), capacity)
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
    Ok(())
}

#[cfg(not(feature = "figures"))]
fn figures(
    _: &mut OutDir,
    _: &Prediction,
    _: &GroundMotion,
    _: Option<f64>,
) -> Result<(), PredictionError> {
    Ok(())
}
