//! Python bindings of `hbis` (module `hbis._hbis`): thin functions over
//! the same library the `hbis` binary uses, arrays in and out. The Python
//! package `hbis` wraps them (`python/hbis/__init__.py`) with pandas and
//! ArviZ conveniences.
//!
//! Every error is a Python `ValueError` whose message is the library
//! error's whole cause chain, as the binary prints it. Heavy work runs with
//! the GIL released; a progress callback re-acquires it only to call back.

use std::collections::BTreeMap;
use std::error::Error as StdError;

use hbis::data::{synthesize as synth, Aligned, Record};
use hbis::inference::ensemble::Moves;
use hbis::inference::map::MapSettings;
use hbis::inference::sample::{Progress, SampleSettings};
use hbis::inference::{Noise, Posterior};
use hbis::model::{ForwardModel, Model, Params, Registry, Response, SimOptions};
use hbis::study::criticize::{self, Setup};
use hbis::study::outputs::{fit_report, ChainOptions, FitRun};
use hbis::study::{fit_record, FitOptions};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rand::{rngs::StdRng, SeedableRng};

/// A library error as a `ValueError` carrying its whole cause chain.
fn err(e: impl StdError) -> PyErr {
    PyValueError::new_err(chain(&e))
}

fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// The built-in catalog with the effect files `effects` loaded (as the
/// binary's `--effects`).
fn registry(effects: &[String]) -> PyResult<Registry> {
    let mut r = Registry::builtin();
    for path in effects {
        r.load_effect_file(std::path::Path::new(path))
            .map_err(|e| value_error(format!("effects: {}", chain(&e))))?;
    }
    Ok(r)
}

/// The registry of `diagnose` and `ladder`: `effects` loaded, then
/// `candidates` (only these offered) and `exclude` (never offered), as the
/// binary's `--candidates` and `--exclude`.
fn criticism_registry(
    effects: &[String],
    candidates: Option<Vec<String>>,
    exclude: &[String],
) -> PyResult<Registry> {
    let mut r = registry(effects)?;
    if let Some(list) = candidates {
        let names: Vec<&str> = list.iter().map(String::as_str).collect();
        r = r
            .with_candidates(&names)
            .map_err(|e| value_error(format!("candidates: {}", chain(&e))))?;
    }
    let names: Vec<&str> = exclude.iter().map(String::as_str).collect();
    r.excluding(&names)
        .map_err(|e| value_error(format!("exclude: {}", chain(&e))))
}

fn parse_model(spec: &str, effects: &[String]) -> PyResult<Model> {
    parse_in(&registry(effects)?, spec)
}

fn parse_in(registry: &Registry, spec: &str) -> PyResult<Model> {
    registry
        .parse(spec)
        .map_err(|e| value_error(format!("model `{spec}`: {}", chain(&e))))
}

fn chain(e: &dyn StdError) -> String {
    let mut msg = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        msg.push_str(": ");
        msg.push_str(&s.to_string());
        src = s.source();
    }
    msg
}

fn parse_noise(noise: &str) -> PyResult<Noise> {
    Noise::parse(noise)
        .ok_or_else(|| value_error(format!("noise `{noise}`: expected `white` or `ar1`")))
}

/// The model's parameter vector from a name -> value mapping: every
/// parameter of the model is required, and no other name is accepted.
fn theta_of(model: &Model, params: &BTreeMap<String, f64>) -> PyResult<Vec<f64>> {
    let names = model.layout().names();
    if let Some(extra) = params.keys().find(|k| !names.contains(k)) {
        return Err(value_error(format!(
            "params: `{extra}` is not a parameter of {} (its parameters: {})",
            model.name(),
            names.join(", ")
        )));
    }
    let theta = names
        .iter()
        .map(|n| {
            params.get(n).copied().ok_or_else(|| {
                value_error(format!(
                    "params: `{n}` is missing (the parameters of {}: {})",
                    model.name(),
                    names.join(", ")
                ))
            })
        })
        .collect::<PyResult<Vec<f64>>>()?;
    model.check(&theta).map_err(err)?;
    Ok(theta)
}

/// The parameters of Table 8.1, Solarino test `k` (3, 5, 6, 7 or 8), by name.
#[pyfunction]
fn table_8_1(k: u32) -> PyResult<BTreeMap<String, f64>> {
    let p = Params::table_8_1(k).ok_or_else(|| {
        value_error(format!(
            "table_8_1({k}): expected a Solarino test of Table 8.1: 3, 5, 6, 7 or 8"
        ))
    })?;
    Ok(hbis::model::ParamName::ALL
        .iter()
        .map(|n| (n.as_str().to_string(), p.get(*n)))
        .collect())
}

/// Parameter names of a model, in its order.
#[pyfunction]
#[pyo3(signature = (model, effects=Vec::new()))]
fn param_names(model: &str, effects: Vec<String>) -> PyResult<Vec<String>> {
    Ok(parse_model(model, &effects)?.layout().names())
}

/// Simulates `model` from release: `(t, u, v, a)` at `t_i = i dt` over
/// `duration` seconds. `a` is what an accelerometer records (output
/// components included); `u` and `v` are the motion (closed form when the
/// model has one, otherwise the numerical engine).
#[pyfunction]
#[pyo3(signature = (model, params, dt, duration, effects=Vec::new()))]
#[allow(clippy::type_complexity)]
fn simulate<'py>(
    py: Python<'py>,
    model: &str,
    params: BTreeMap<String, f64>,
    dt: f64,
    duration: f64,
    effects: Vec<String>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
)> {
    let m = parse_model(model, &effects)?;
    let theta = theta_of(&m, &params)?;
    if !(dt.is_finite() && dt > 0.0 && duration.is_finite() && duration >= 0.0) {
        return Err(value_error(format!(
            "dt = {dt}, duration = {duration}: expected dt > 0 and duration >= 0 (s)"
        )));
    }
    let n = (duration / dt + 1e-9).floor() as usize + 1;
    let (u, v, a) = py
        .detach(|| -> Result<_, hbis::model::SimError> {
            let mut a = vec![0.0; n];
            m.accel_into(&theta, dt, &mut a)?;
            let (u, v) = if m.closed_form() {
                let response =
                    Response::of_system(m.system(&theta)?, duration, &SimOptions::default())?;
                let s = response.sample_grid(dt)?;
                (
                    s.iter().take(n).map(|x| x.u).collect::<Vec<_>>(),
                    s.iter().take(n).map(|x| x.v).collect::<Vec<_>>(),
                )
            } else {
                let s = m.motion_grid(&theta, 0.0, dt, n)?;
                (
                    s.iter().map(|x| x.u).collect(),
                    s.iter().map(|x| x.v).collect(),
                )
            };
            Ok((u, v, a))
        })
        .map_err(err)?;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    Ok((
        t.into_pyarray(py),
        u.into_pyarray(py),
        v.into_pyarray(py),
        a.into_pyarray(py),
    ))
}

/// A synthetic record: `model` with `params` sampled `n` times at `dt`,
/// plus white Gaussian noise of `noise` times the peak |a| (seeded).
/// Returns `(t, a, clean, sigma)`.
#[pyfunction]
#[pyo3(signature = (model, params, dt, n, noise, seed, effects=Vec::new()))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn synthesize<'py>(
    py: Python<'py>,
    model: &str,
    params: BTreeMap<String, f64>,
    dt: f64,
    n: usize,
    noise: f64,
    seed: u64,
    effects: Vec<String>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    f64,
)> {
    let m = parse_model(model, &effects)?;
    let theta = theta_of(&m, &params)?;
    let mut rng = StdRng::seed_from_u64(seed);
    let s = synth(&m, &theta, dt, n, noise, &mut rng).map_err(err)?;
    Ok((
        s.record.t().to_vec().into_pyarray(py),
        s.record.a().to_vec().into_pyarray(py),
        s.clean.into_pyarray(py),
        s.sigma,
    ))
}

/// A record checked as the binary checks a file, then aligned at the
/// release (detected, or `t0` in the record's clock).
fn aligned(t: &[f64], a: &[f64], t0: Option<f64>) -> PyResult<Aligned> {
    Ok(aligned_with_warnings(t, a, t0)?.0)
}

/// [`aligned`] with the record's warnings, as the binary's reports list
/// them first.
fn aligned_with_warnings(
    t: &[f64],
    a: &[f64],
    t0: Option<f64>,
) -> PyResult<(Aligned, Vec<hbis::data::Warning>)> {
    let record = Record::new(t.to_vec(), a.to_vec()).map_err(err)?;
    let data = record.aligned(t0).map_err(err)?;
    let warnings = hbis::data::record_warnings(&record, &data);
    Ok((data, warnings))
}

/// Reads a record file as the binary does (CSV with columns `t`, `a`, or
/// whitespace-separated text), converting `units` (`m/s2`, `g`, `mm/s2`)
/// to m/s^2: `(t, a)`.
#[pyfunction]
#[pyo3(signature = (path, units="m/s2"))]
#[allow(clippy::type_complexity)]
fn read_record<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    units: &str,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
    let u: hbis::data::AccelUnits = units
        .parse()
        .map_err(|e| value_error(format!("units `{units}`: {}", chain(&e))))?;
    let r = Record::read(&path)
        .and_then(|r| r.in_units(u))
        .map_err(|e| value_error(format!("in record {}: {}", path.display(), chain(&e))))?;
    Ok((
        r.t().to_vec().into_pyarray(py),
        r.a().to_vec().into_pyarray(py),
    ))
}

/// Checks a record `(t, a)` (SI units) and returns the aligned record:
/// `(t, a, t0, source)` from the release on.
#[pyfunction]
#[pyo3(signature = (t, a, t0=None))]
#[allow(clippy::type_complexity)]
fn align<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    a: PyReadonlyArray1<'py, f64>,
    t0: Option<f64>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    f64,
    String,
)> {
    let d = aligned(t.as_slice()?, a.as_slice()?, t0)?;
    let times: Vec<f64> = (0..d.a.len()).map(|i| d.time(i)).collect();
    Ok((
        times.into_pyarray(py),
        d.a.clone().into_pyarray(py),
        d.t0,
        format!("{:?}", d.source).to_lowercase(),
    ))
}

/// What [`fit`] returns: the report (as `fit.json` would hold it), the
/// kept draws as `(chain, draw, param)` and eq. 8.1 per draw.
#[pyclass(module = "hbis._hbis", frozen)]
struct FitResult {
    #[pyo3(get)]
    names: Vec<String>,
    #[pyo3(get)]
    report_json: String,
    #[pyo3(get)]
    thin: usize,
    draws: Option<Array3<f64>>,
    log_prob: Option<Array3<f64>>,
    physical: Option<Array3<f64>>,
}

#[pymethods]
impl FitResult {
    /// Kept draws, `(chain, draw, param)`; `None` for a MAP-only fit.
    #[getter]
    fn draws<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.draws.clone().map(|d| d.into_pyarray(py))
    }

    /// Log-posterior of each kept draw, `(chain, draw, 1)`.
    #[getter]
    fn log_prob<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.log_prob.clone().map(|d| d.into_pyarray(py))
    }

    /// `m, k0, k1, k2, kF, c` (eq. 8.1, Table 8.2 units) per kept draw,
    /// `(chain, draw, 6)`; `None` without forces.
    #[getter]
    fn physical<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.physical.clone().map(|d| d.into_pyarray(py))
    }
}

/// Kept steps `burn, burn + thin, ...` of every ensemble, walker-major
/// (as the chain files): `(chain, walker * steps, k)` arrays of the draws,
/// log-posteriors and (with forces) eq. 8.1.
type Arrays = (Array3<f64>, Array3<f64>, Option<Array3<f64>>);

fn kept_arrays(
    fit: &hbis::study::Fit,
    thin: usize,
    forces: Option<(f64, f64)>,
) -> PyResult<Arrays> {
    let sample = fit.sample.as_ref().expect("a sampled fit");
    let steps: Vec<usize> = hbis::report::cmdstan::kept_steps(sample, thin).collect();
    let chains = sample.chains.len();
    let walkers = sample.chains.first().map_or(0, |c| c.walkers());
    let dim = sample.names.len();
    let per = walkers * steps.len();
    let mut draws = Array3::<f64>::zeros((chains, per, dim));
    let mut lp = Array3::<f64>::zeros((chains, per, 1));
    let mut phys = forces.map(|_| Array3::<f64>::zeros((chains, per, 6)));
    for (e, c) in sample.chains.iter().enumerate() {
        for w in 0..walkers {
            for (j, &s) in steps.iter().enumerate() {
                let i = w * steps.len() + j;
                let x = c.get(s, w);
                for (k, v) in x.iter().enumerate() {
                    draws[[e, i, k]] = *v;
                }
                lp[[e, i, 0]] = c.log_prob_at(s, w);
                if let (Some(p), Some((f, st))) = (phys.as_mut(), forces) {
                    let q = hbis::study::physical_of(&fit.posterior, x, f, st).map_err(err)?;
                    for (k, v) in q.into_iter().enumerate() {
                        p[[e, i, k]] = v;
                    }
                }
            }
        }
    }
    Ok((draws, lp, phys))
}

/// Fits a record: the MAP (CMA-ES and polish), then, unless `map_only`,
/// the posterior by the ensemble sampler with the binary's defaults.
/// Same inputs and seed give the numbers `hbis fit` gives.
#[pyfunction]
#[pyo3(signature = (
    t, a, model="trilinear+lcfm+viscous", noise="white", seed=1, t0=None,
    map_only=false, ensembles=hbis::inference::sample::DEFAULT_ENSEMBLES, walkers=None, tau_multiple=50.0,
    max_steps=20_000, ess=None, moves=None, max_evals=200_000, evidence=false,
    forces=None, design_target=Some(0.5), thin=None, source="array", progress=None,
    effects=Vec::new(),
))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    t: PyReadonlyArray1<'_, f64>,
    a: PyReadonlyArray1<'_, f64>,
    model: &str,
    noise: &str,
    seed: u64,
    t0: Option<f64>,
    map_only: bool,
    ensembles: usize,
    walkers: Option<usize>,
    tau_multiple: f64,
    max_steps: usize,
    ess: Option<f64>,
    moves: Option<&str>,
    max_evals: usize,
    evidence: bool,
    forces: Option<(f64, f64)>,
    design_target: Option<f64>,
    thin: Option<usize>,
    source: &str,
    progress: Option<Py<PyAny>>,
    effects: Vec<String>,
) -> PyResult<FitResult> {
    let m = parse_model(model, &effects)?;
    let noise_model = parse_noise(noise)?;
    let (data, record_warnings) = aligned_with_warnings(t.as_slice()?, a.as_slice()?, t0)?;
    if thin == Some(0) {
        return Err(value_error(
            "thin = 0: expected a whole number of steps >= 1 (1 keeps every step)",
        ));
    }
    if let Some(d) = design_target.filter(|d| !(*d > 0.0 && *d < 1.0)) {
        return Err(value_error(format!(
            "design_target = {d}: expected a fraction of today's sd in (0, 1), e.g. 0.5"
        )));
    }
    let mut sample = SampleSettings::default()
        .with_ensembles(ensembles)
        .map_err(|e| value_error(format!("ensembles: {}", chain(&e))))?
        .with_tau_multiple(tau_multiple)
        .map_err(|e| value_error(format!("tau_multiple: {}", chain(&e))))?
        .with_max_steps(max_steps)
        .map_err(|e| value_error(format!("max_steps: {}", chain(&e))))?;
    if let Some(w) = walkers {
        sample = sample
            .with_walkers(w)
            .map_err(|e| value_error(format!("walkers: {}", chain(&e))))?;
    }
    if let Some(n) = ess {
        sample = sample
            .with_ess(n)
            .map_err(|e| value_error(format!("ess: {}", chain(&e))))?;
    }
    if let Some(text) = moves {
        let mv = Moves::parse(text).map_err(|e| value_error(format!("moves `{text}`: {e}")))?;
        sample = sample.with_moves(mv);
    }
    let options = FitOptions {
        seed,
        map: MapSettings::default()
            .with_max_evals(max_evals)
            .map_err(|e| value_error(format!("max_evals: {}", chain(&e))))?,
        sample: (!map_only).then_some(sample),
        checkpoint: None,
        forces,
        label: source.to_string(),
        evidence,
        design_target,
    };
    let priors = Posterior::default_priors(&m, noise_model);
    let fitted = py
        .detach(|| {
            let mut report = |p: Progress| {
                if let Some(cb) = &progress {
                    Python::attach(|py| {
                        // A failing callback must not stop the fit.
                        let _ = cb.call1(py, (p.steps, p.target_steps.max(p.steps), p.tau_max));
                    });
                }
            };
            fit_record(m, data, Some(priors), noise_model, &options, &mut report)
        })
        .map_err(err)?;
    let every = match (&fitted.sample, thin) {
        (Some(_), Some(k)) => k,
        (Some(s), None) => hbis::report::cmdstan::auto_thin(s),
        (None, _) => 1,
    };
    let run = FitRun {
        source: source.to_string(),
        seed,
        noise: noise_model,
        record_warnings,
        chains: ChainOptions {
            thin,
            ..Default::default()
        },
    };
    let report = fit_report(
        &fitted,
        &run,
        Vec::new(),
        fitted.sample.as_ref().map(|_| every),
    );
    let report_json = serde_json::to_string(&report).map_err(err)?;
    let (draws, log_prob, physical) = if fitted.sample.is_some() {
        let (d, l, p) = kept_arrays(&fitted, every, forces)?;
        (Some(d), Some(l), p)
    } else {
        (None, None, None)
    };
    Ok(FitResult {
        names: fitted.names().to_vec(),
        report_json,
        thin: every,
        draws,
        log_prob,
        physical,
    })
}

/// The start model, the record (release placed) and the noise model, as
/// `hbis diagnose` and `hbis ladder` set them up; `noise = "auto"` picks by BIC.
#[allow(clippy::too_many_arguments)]
fn criticism_setup(
    registry: &Registry,
    t: &[f64],
    a: &[f64],
    model: &str,
    noise: &str,
    seed: u64,
    t0: Option<f64>,
    source: &str,
) -> PyResult<Setup> {
    let m = parse_in(registry, model)?;
    let asked = criticize::parse_noise(noise).ok_or_else(|| {
        value_error(format!(
            "noise `{noise}`: expected `white`, `ar1` or `auto`"
        ))
    })?;
    let (data, warnings) = aligned_with_warnings(t, a, t0)?;
    criticize::setup(m, data, asked, seed, source, warnings).map_err(err)
}

/// `hbis diagnose` on arrays: `diagnosis.json`'s text, the same runner's
/// report.
#[pyfunction]
#[pyo3(signature = (t, a, model, noise="white", seed=1, t0=None, effects=Vec::new(), candidates=None, exclude=Vec::new(), source="array"))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    t: PyReadonlyArray1<'_, f64>,
    a: PyReadonlyArray1<'_, f64>,
    model: &str,
    noise: &str,
    seed: u64,
    t0: Option<f64>,
    effects: Vec<String>,
    candidates: Option<Vec<String>>,
    exclude: Vec<String>,
    source: &str,
) -> PyResult<String> {
    let (t, a) = (t.as_slice()?.to_vec(), a.as_slice()?.to_vec());
    let registry = criticism_registry(&effects, candidates, &exclude)?;
    py.detach(|| -> PyResult<String> {
        let s = criticism_setup(&registry, &t, &a, model, noise, seed, t0, source)?;
        let d = criticize::diagnose(&registry, &s, &MapSettings::default()).map_err(err)?;
        serde_json::to_string(&d.report).map_err(err)
    })
}

/// `hbis ladder` on arrays: `ladder.json`'s text, the same runner's report;
/// `progress(step_index, model)` after each step.
#[pyfunction]
#[pyo3(signature = (t, a, model, noise="white", seed=1, t0=None, max_steps=6, progress=None, effects=Vec::new(), candidates=None, exclude=Vec::new(), source="array"))]
#[allow(clippy::too_many_arguments)]
fn ladder(
    py: Python<'_>,
    t: PyReadonlyArray1<'_, f64>,
    a: PyReadonlyArray1<'_, f64>,
    model: &str,
    noise: &str,
    seed: u64,
    t0: Option<f64>,
    max_steps: usize,
    progress: Option<Py<PyAny>>,
    effects: Vec<String>,
    candidates: Option<Vec<String>>,
    exclude: Vec<String>,
    source: &str,
) -> PyResult<String> {
    let (t, a) = (t.as_slice()?.to_vec(), a.as_slice()?.to_vec());
    let registry = criticism_registry(&effects, candidates, &exclude)?;
    py.detach(|| -> PyResult<String> {
        let s = criticism_setup(&registry, &t, &a, model, noise, seed, t0, source)?;
        let mut k = 0usize;
        let mut on_step = |step: &hbis::criticism::Step| {
            if let Some(cb) = &progress {
                Python::attach(|py| {
                    let _ = cb.call1(py, (k, step.model.clone()));
                });
            }
            k += 1;
        };
        let l = criticize::ladder(
            &registry,
            &s,
            &MapSettings::default(),
            max_steps,
            &mut on_step,
        )
        .map_err(err)?;
        serde_json::to_string(&l.report).map_err(err)
    })
}

/// A synthetic Kanai-Tajimi ground motion (firm soil by default) of
/// `seed`, scaled to `pga` (m/s^2): the ground acceleration at `i dt`.
#[pyfunction]
#[pyo3(signature = (seed, pga = 0.3 * 9.80665, duration = 40.0, dt = 0.01, f_g = 2.5, zeta_g = 0.6))]
fn kanai_tajimi<'py>(
    py: Python<'py>,
    seed: u64,
    pga: f64,
    duration: f64,
    dt: f64,
    f_g: f64,
    zeta_g: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let kt = hbis::data::ground_motion::KanaiTajimi {
        pga,
        duration,
        dt,
        f_g,
        zeta_g,
        ..Default::default()
    };
    Ok(kt.generate(seed).map_err(err)?.ag.into_pyarray(py))
}

/// Reads a ground motion: PEER `.AT2` (unit from its header unless
/// `units` is given) or two columns `t ag` (`units` required). Returns
/// `(dt, ag)` with `ag` in m/s^2.
#[pyfunction]
#[pyo3(signature = (path, units = None))]
fn read_motion<'py>(
    py: Python<'py>,
    path: &str,
    units: Option<&str>,
) -> PyResult<(f64, Bound<'py, PyArray1<f64>>)> {
    use hbis::data::ground_motion::GroundMotion;
    use hbis::data::validation::AccelUnits;
    let units = units
        .map(|u| {
            u.parse::<AccelUnits>()
                .map_err(|e| value_error(format!("units `{u}`: {}", chain(&e))))
        })
        .transpose()?;
    let p = std::path::Path::new(path);
    let m = if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("at2")) {
        GroundMotion::read_at2(p, units)
    } else {
        let u = units.ok_or_else(|| {
            value_error(format!(
                "{path}: state the unit of a two-column motion: units='g', 'm/s2' or 'mm/s2'"
            ))
        })?;
        GroundMotion::read_columns(p, u)
    }
    .map_err(err)?;
    Ok((m.dt, m.ag.into_pyarray(py)))
}

/// Each parameter set (rows of `thetas`, in the model's order) under the
/// ground acceleration `ag` (m/s^2, step `dt`) from rest, `tail` seconds
/// after: per set `(peak_displacement, residual_displacement,
/// peak_base_shear, peak_total_acceleration)` as an `(n, 4)` array, and
/// the summary as `predict.json` holds it (JSON text).
#[pyfunction]
#[pyo3(signature = (model, thetas, dt, ag, tail = 20.0, capacity = None, masses = None, effects = Vec::new()))]
#[allow(clippy::too_many_arguments)]
fn predict<'py>(
    py: Python<'py>,
    model: &str,
    thetas: Vec<Vec<f64>>,
    dt: f64,
    ag: PyReadonlyArray1<'py, f64>,
    tail: f64,
    capacity: Option<f64>,
    masses: Option<Vec<f64>>,
    effects: Vec<String>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
    let m = parse_model(model, &effects)?;
    let width = m.layout().names().len();
    if let Some(bad) = thetas.iter().position(|t| t.len() != width) {
        return Err(value_error(format!(
            "thetas row {bad}: {} values, the model {} has {width} parameters ({})",
            thetas[bad].len(),
            m.name(),
            m.layout().names().join(", ")
        )));
    }
    if let Some(ms) = &masses {
        if ms.len() != thetas.len() {
            return Err(value_error(format!(
                "masses: {} values for {} parameter sets",
                ms.len(),
                thetas.len()
            )));
        }
    }
    for (i, t) in thetas.iter().enumerate() {
        m.check(t)
            .map_err(|e| value_error(format!("thetas row {i}: {}", chain(&e))))?;
    }
    let ag = ag.as_slice()?.to_vec();
    let draws: Vec<hbis::predict::Draw> = thetas
        .into_iter()
        .enumerate()
        .map(|(i, theta)| hbis::predict::Draw {
            theta,
            mass: masses.as_ref().map(|ms| ms[i]),
            origin: None,
        })
        .collect();
    let opts = hbis::predict::PredictOptions {
        tail,
        capacity,
        band_points: 0,
    };
    let p = py
        .detach(|| hbis::predict::predict(&m, &draws, dt, &ag, &opts))
        .map_err(err)?;
    let mut rows = Array2::<f64>::zeros((p.outcomes.len(), 4));
    for (i, o) in p.outcomes.iter().enumerate() {
        let k = &o.peaks;
        rows[[i, 0]] = k.peak_displacement;
        rows[[i, 1]] = k.residual_displacement;
        rows[[i, 2]] = k.peak_base_shear;
        rows[[i, 3]] = k.peak_total_acceleration;
    }
    let json = serde_json::json!({
        "draws": draws.len(),
        "summary": p.summary,
        "p_exceed_capacity": p.p_exceed_capacity,
        "extrapolation": p.extrapolation,
        "warnings": p.warnings,
    });
    Ok((rows.into_pyarray(py), json.to_string()))
}

/// The compiled part of the `hbis` package.
#[pymodule]
fn _hbis(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(table_8_1, m)?)?;
    m.add_function(wrap_pyfunction!(param_names, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(synthesize, m)?)?;
    m.add_function(wrap_pyfunction!(align, m)?)?;
    m.add_function(wrap_pyfunction!(read_record, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(ladder, m)?)?;
    m.add_function(wrap_pyfunction!(kanai_tajimi, m)?)?;
    m.add_function(wrap_pyfunction!(read_motion, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_class::<FitResult>()?;
    Ok(())
}
