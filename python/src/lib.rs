//! Python bindings of `hbis` (module `hbis._hbis`): thin functions over
//! the same library the `hbis` binary uses, arrays in and out. The Python
//! package `hbis` wraps them (`python/hbis/__init__.py`) with pandas and
//! ArviZ conveniences.
//!
//! Every error in the inputs is a Python `ValueError` (a `TypeError` for a
//! wrong type) whose message names the argument and carries the library
//! error's whole cause chain, as the binary prints it. Sizes the binary
//! refuses are refused before anything is allocated.
//!
//! Long runs (`simulate`, `fit`, `diagnose`, `ladder`, `predict`) run on a
//! thread of their own with the GIL released, while the calling thread
//! checks for signals every [`POLL`]: Ctrl-C raises `KeyboardInterrupt`
//! within a fraction of a second ([`interruptible`]). A progress callback
//! takes the GIL only to call back; an exception it raises ends the run and
//! is raised from the call.

use std::collections::BTreeMap;
use std::error::Error as StdError;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use hbis::cancel::Cancel;
use hbis::data::record::check_size;
use hbis::data::{limits, synthesize as synth, Aligned, Record};
use hbis::inference::ensemble::Moves;
use hbis::inference::map::MapSettings;
use hbis::inference::pointwise::pointwise_log_likelihood;
use hbis::inference::sample::{Progress, SampleSettings};
use hbis::inference::{Noise, Posterior};
use hbis::model::response::grid_len;
use hbis::model::{ForwardModel, Model, Params, Registry, Response, SimOptions};
use hbis::study::criticize::{self, Setup};
use hbis::study::outputs::{fit_report, ChainOptions, FitRun};
use hbis::study::{fit_record, FitOptions};
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOverflowError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use rand::{rngs::StdRng, SeedableRng};

/// A library error as a `ValueError` carrying its whole cause chain.
fn err(e: impl StdError) -> PyErr {
    PyValueError::new_err(chain(&e))
}

fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// How often the calling thread checks for signals while a run works.
const POLL: Duration = Duration::from_millis(50);

/// Stack of a run's thread: a main thread's (the library's recursion
/// depth was only ever tried on one).
const RUN_STACK: usize = 8 << 20;

/// The unwind payload that ends a run the caller has given up on (Ctrl-C
/// or a failing callback). `resume_unwind` does not call the panic hook,
/// so nothing is printed.
struct Abandoned;

/// Shared between a run's thread and the caller: whether the caller gave
/// up, and the exception a callback raised.
#[derive(Clone, Default)]
struct Run {
    abandoned: Arc<AtomicBool>,
    /// Tells the library's loops to stop (a MAP search, a diagnosis's
    /// refits, a prediction's draws), so an abandoned run stops computing.
    cancel: Cancel,
    raised: Arc<Mutex<Option<PyErr>>>,
}

impl Run {
    fn give_up(&self) {
        self.abandoned.store(true, Ordering::SeqCst);
        self.cancel.cancel();
    }

    /// MAP settings (the binary's defaults) that stop when the run is
    /// given up.
    fn map_settings(&self) -> MapSettings {
        MapSettings::default()
            .with_cancel(Some(self.cancel.clone()))
            .expect("a token is always a valid setting")
    }

    /// Ends the run (unwinding out of the library from its progress hook)
    /// when the caller has given up on it.
    fn check(&self) {
        if self.abandoned.load(Ordering::SeqCst) {
            panic::resume_unwind(Box::new(Abandoned));
        }
    }

    /// Calls back into Python with the GIL; an exception raised there ends
    /// the run, and [`interruptible`] raises it from the call.
    fn call_back<R>(&self, f: impl FnOnce(Python<'_>) -> PyResult<R>) {
        self.check();
        let raised = Python::attach(|py| {
            if self.abandoned.load(Ordering::SeqCst) {
                return None;
            }
            f(py).err()
        });
        if let Some(e) = raised {
            *self.raised.lock().unwrap_or_else(PoisonError::into_inner) = Some(e);
            self.give_up();
        }
        self.check();
    }
}

/// Runs `work` on a thread of its own with the GIL released, while the
/// calling thread checks for signals every [`POLL`]: a signal handler's
/// exception (`KeyboardInterrupt` on Ctrl-C) is raised at once, and the run
/// is told to stop at its next progress hook ([`Run::check`]); its result
/// is dropped, so nothing of it is left. An exception raised by a callback
/// ([`Run::call_back`]) is raised here; a panic in the library is re-raised
/// on this thread (pyo3 makes it a `PanicException`, as before).
fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    run: &Run,
    work: impl FnOnce() -> PyResult<T> + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("hbis-run".into())
        .stack_size(RUN_STACK)
        .spawn(move || {
            // On a worker of the pool: the run's parallel calls are split
            // at once, not handed over (`hbis::parallel`).
            let work = || hbis::parallel::on_pool(work);
            let _ = tx.send(panic::catch_unwind(AssertUnwindSafe(work)));
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a thread for the run: {e}")))?;
    let mut rx = rx;
    loop {
        // The receiver goes into the GIL-free closure and comes back (it
        // is not `Sync`, so it cannot be borrowed there).
        let (got, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
        rx = back;
        match got {
            Ok(Ok(result)) => return result,
            Ok(Err(payload)) if payload.is::<Abandoned>() => {
                let raised = run
                    .raised
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .take();
                return Err(raised.unwrap_or_else(|| {
                    PyRuntimeError::new_err("the run was abandoned without a cause")
                }));
            }
            Ok(Err(payload)) => panic::resume_unwind(payload),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    run.give_up();
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(
                    "the run's thread ended without a result",
                ))
            }
        }
    }
}

/// `obj`'s repr and type, for an error message.
fn shown(obj: &Bound<'_, PyAny>) -> String {
    let repr = obj
        .repr()
        .map_or_else(|_| "?".to_string(), |r| r.to_string());
    let ty = obj
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    format!("{repr} ({ty})")
}

/// A whole-number argument in `0..=max`, or an error naming it: a
/// `ValueError` for a negative or too large integer, a `TypeError` for
/// anything else.
fn whole(obj: &Bound<'_, PyAny>, name: &str, max: u64) -> PyResult<u64> {
    let too_large = || {
        value_error(format!(
            "{name}: expected a whole number at most {max}, got {}",
            shown(obj)
        ))
    };
    match obj.extract::<u64>() {
        Ok(v) if v <= max => Ok(v),
        Ok(_) => Err(too_large()),
        Err(e) if e.is_instance_of::<PyOverflowError>(obj.py()) => {
            if obj.lt(0).unwrap_or(false) {
                Err(value_error(format!(
                    "{name}: expected a non-negative integer, got {}",
                    shown(obj)
                )))
            } else {
                Err(too_large())
            }
        }
        Err(_) => Err(PyTypeError::new_err(format!(
            "{name}: expected a non-negative integer, got {}",
            shown(obj)
        ))),
    }
}

fn count(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    // `max` is usize::MAX, so the value fits.
    whole(obj, name, usize::MAX as u64).map(|v| v as usize)
}

fn maybe_count(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Option<usize>> {
    if obj.is_none() {
        return Ok(None);
    }
    count(obj, name).map(Some)
}

// Extractors of the integer arguments (`#[pyo3(from_py_with = ...)]`), so
// that every error names its argument.
fn seed_arg(obj: &Bound<'_, PyAny>) -> PyResult<u64> {
    whole(obj, "seed", u64::MAX)
}
fn k_arg(obj: &Bound<'_, PyAny>) -> PyResult<u32> {
    whole(obj, "k", u32::MAX.into()).map(|v| v as u32)
}
fn n_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "n")
}
fn ensembles_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "ensembles")
}
fn max_steps_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "max_steps")
}
fn max_evals_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "max_evals")
}
fn walkers_arg(obj: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    maybe_count(obj, "walkers")
}
fn thin_arg(obj: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
    maybe_count(obj, "thin")
}

/// A shape as Python prints it: `(3, 2)`, `(3,)`, `()`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// A 1-D float64 numpy array argument, or an error naming it and what it
/// got: a `ValueError` for another shape, a `TypeError` for another dtype
/// or a non-array.
fn array1<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let Ok(any) = obj.cast::<PyUntypedArray>() else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a 1-D numpy array of float64, got {}",
            shown(obj)
        )));
    };
    if any.ndim() != 1 {
        return Err(value_error(format!(
            "{name}: expected a 1-D array, got shape {}",
            shape_text(any.shape())
        )));
    }
    match obj.cast::<PyArray1<f64>>() {
        Ok(a) => Ok(a.clone()),
        Err(_) => Err(PyTypeError::new_err(format!(
            "{name}: expected an array of float64, got dtype {}",
            any.dtype()
        ))),
    }
}

fn t_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    array1(obj, "t")
}
fn a_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    array1(obj, "a")
}
fn ag_arg<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    array1(obj, "ag")
}

/// The values of a checked array (any strides).
fn values(a: &Bound<'_, PyArray1<f64>>) -> PyResult<Vec<f64>> {
    Ok(a.try_readonly()?.as_array().iter().copied().collect())
}

/// A record `(t, a)` within the reader's limit ([`MAX_SAMPLES`](hbis::data::MAX_SAMPLES)), refused
/// in its words before it is copied.
fn record_arrays(
    t: &Bound<'_, PyArray1<f64>>,
    a: &Bound<'_, PyArray1<f64>>,
) -> PyResult<(Vec<f64>, Vec<f64>)> {
    check_size(t.len().max(a.len())).map_err(err)?;
    Ok((values(t)?, values(a)?))
}

/// Refuses a grid too long to hold, before allocating it, in the words of
/// `hbis simulate` ([`limits::grid`]); the number of samples otherwise.
fn check_grid_size(dt: f64, duration: f64) -> PyResult<usize> {
    limits::grid(dt, duration).map_err(err)?;
    Ok(grid_len(dt, duration))
}

/// Refuses, before the MAP, a sampler the stretch move cannot run or whose
/// chains could not fit in memory, in the words of `hbis fit`
/// ([`limits::sampler`]).
fn check_sampler_size(dim: usize, w: usize, ensembles: usize, max_steps: usize) -> PyResult<()> {
    limits::sampler(dim, w, ensembles, max_steps).map_err(err)
}

/// A physical argument that must be a finite number > 0, refused in the
/// library's words ([`hbis::predict::positive`]), as `hbis predict` does.
fn check_positive(name: &str, v: f64) -> PyResult<()> {
    hbis::predict::positive(name, v).map_err(err)
}

/// A progress callback, checked to be callable before any work.
fn check_callable(py: Python<'_>, progress: &Option<Py<PyAny>>, signature: &str) -> PyResult<()> {
    match progress {
        Some(cb) if !cb.bind(py).is_callable() => Err(PyTypeError::new_err(format!(
            "progress: expected a callable {signature} or None, got {}",
            shown(cb.bind(py))
        ))),
        _ => Ok(()),
    }
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
fn table_8_1(#[pyo3(from_py_with = k_arg)] k: u32) -> PyResult<BTreeMap<String, f64>> {
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
/// model has one, otherwise the numerical engine). More samples than
/// `hbis simulate` writes (1e7) are refused.
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
    let n = check_grid_size(dt, duration)?;
    let (u, v, a) = interruptible(py, &Run::default(), move || {
        (|| -> Result<_, hbis::model::SimError> {
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
        })()
        .map_err(err)
    })?;
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
/// Returns `(t, a, clean, sigma)`. More samples than a record may hold
/// ([`MAX_SAMPLES`](hbis::data::MAX_SAMPLES)) are refused.
#[pyfunction]
#[pyo3(signature = (model, params, dt, n, noise, seed, effects=Vec::new()))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn synthesize<'py>(
    py: Python<'py>,
    model: &str,
    params: BTreeMap<String, f64>,
    dt: f64,
    #[pyo3(from_py_with = n_arg)] n: usize,
    noise: f64,
    #[pyo3(from_py_with = seed_arg)] seed: u64,
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
    #[pyo3(from_py_with = t_arg)] t: Bound<'py, PyArray1<f64>>,
    #[pyo3(from_py_with = a_arg)] a: Bound<'py, PyArray1<f64>>,
    t0: Option<f64>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    f64,
    String,
)> {
    let (t, a) = record_arrays(&t, &a)?;
    let d = aligned(&t, &a, t0)?;
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
    /// The fit's posterior (model, record as fitted, noise model), for the
    /// pointwise log-likelihood of its draws.
    posterior: Posterior<Model>,
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

    /// The record as fitted (release placed, polarity applied), m/s^2.
    #[getter]
    fn observed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.posterior.data().a.clone().into_pyarray(py)
    }

    /// The pointwise log-likelihood of every kept draw, `(chain, draw,
    /// sample)`, for `az.loo` (`hbis::inference::pointwise`: `sigma` drawn
    /// from its conditional posterior per draw, from `seed`); `None` for a
    /// MAP-only fit.
    fn log_likelihood<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = seed_arg)] seed: u64,
    ) -> PyResult<Option<Bound<'py, PyArray3<f64>>>> {
        let Some(draws) = &self.draws else {
            return Ok(None);
        };
        let (chains, per, _) = draws.dim();
        let n = self.posterior.data().a.len();
        limits::pointwise(chains * per, n).map_err(err)?;
        let draws = draws.clone();
        let posterior = self.posterior.clone();
        let out = interruptible(py, &Run::default(), move || {
            pointwise_array(&posterior, &draws, seed).map_err(err)
        })?;
        Ok(Some(out.into_pyarray(py)))
    }
}

/// [`FitResult::log_likelihood`]'s array: each draw's `sigma` from a seed
/// of its own, drawn in order from `seed`, so the result does not depend
/// on the number of threads.
fn pointwise_array(
    posterior: &Posterior<Model>,
    draws: &Array3<f64>,
    seed: u64,
) -> Result<Array3<f64>, hbis::model::SimError> {
    use rand::RngExt;
    use rayon::prelude::*;
    let (chains, per, _) = draws.dim();
    let n = posterior.data().a.len();
    let mut rng = StdRng::seed_from_u64(seed);
    let seeds: Vec<u64> = (0..chains * per).map(|_| rng.random()).collect();
    let mut out = Array3::<f64>::zeros((chains, per, n));
    let slice = out.as_slice_mut().expect("a new array is contiguous");
    slice
        .par_chunks_mut(n)
        .zip(seeds)
        .enumerate()
        .try_for_each(|(k, (row, s))| {
            let theta: Vec<f64> = draws
                .slice(numpy::ndarray::s![k / per, k % per, ..])
                .to_vec();
            let mut rng = StdRng::seed_from_u64(s);
            pointwise_log_likelihood(posterior, &theta, &mut rng, row).map(|_| ())
        })?;
    Ok(out)
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
/// Same inputs and seed give the numbers `hbis fit` gives. The fit runs on
/// a thread of its own ([`interruptible`]): Ctrl-C raises
/// `KeyboardInterrupt` at once, and an exception raised by `progress` ends
/// the fit and is raised here.
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
    #[pyo3(from_py_with = t_arg)] t: Bound<'_, PyArray1<f64>>,
    #[pyo3(from_py_with = a_arg)] a: Bound<'_, PyArray1<f64>>,
    model: &str,
    noise: &str,
    #[pyo3(from_py_with = seed_arg)] seed: u64,
    t0: Option<f64>,
    map_only: bool,
    #[pyo3(from_py_with = ensembles_arg)] ensembles: usize,
    #[pyo3(from_py_with = walkers_arg)] walkers: Option<usize>,
    tau_multiple: f64,
    #[pyo3(from_py_with = max_steps_arg)] max_steps: usize,
    ess: Option<f64>,
    moves: Option<&str>,
    #[pyo3(from_py_with = max_evals_arg)] max_evals: usize,
    evidence: bool,
    forces: Option<(f64, f64)>,
    design_target: Option<f64>,
    #[pyo3(from_py_with = thin_arg)] thin: Option<usize>,
    source: &str,
    progress: Option<Py<PyAny>>,
    effects: Vec<String>,
) -> PyResult<FitResult> {
    check_callable(py, &progress, "progress(steps, target_steps, tau_max)")?;
    let m = parse_model(model, &effects)?;
    let noise_model = parse_noise(noise)?;
    let (t, a) = record_arrays(&t, &a)?;
    let (data, record_warnings) = aligned_with_warnings(&t, &a, t0)?;
    drop((t, a));
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
    if !map_only {
        let dim = Posterior::<Model>::names_for(&m, noise_model).len();
        check_sampler_size(dim, sample.walkers_for(dim), ensembles, max_steps)?;
    }
    let run = Run::default();
    let options = FitOptions {
        seed,
        map: run
            .map_settings()
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
    let source = source.to_string();
    let hook = run.clone();
    interruptible(py, &run, move || {
        let mut report = |p: Progress| {
            hook.check();
            if let Some(cb) = &progress {
                hook.call_back(|py| {
                    cb.call1(py, (p.steps, p.target_steps.max(p.steps), p.tau_max))
                });
            }
        };
        let fitted =
            fit_record(m, data, Some(priors), noise_model, &options, &mut report).map_err(err)?;
        let every = match (&fitted.sample, thin) {
            (Some(_), Some(k)) => k,
            (Some(s), None) => hbis::report::cmdstan::auto_thin(s),
            (None, _) => 1,
        };
        let run = FitRun {
            source,
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
            posterior: fitted.posterior.clone(),
            names: fitted.names().to_vec(),
            report_json,
            thin: every,
            draws,
            log_prob,
            physical,
        })
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
    settings: &MapSettings,
) -> PyResult<Setup> {
    let m = parse_in(registry, model)?;
    let asked = criticize::parse_noise(noise).ok_or_else(|| {
        value_error(format!(
            "noise `{noise}`: expected `white`, `ar1` or `auto`"
        ))
    })?;
    let (data, warnings) = aligned_with_warnings(t, a, t0)?;
    criticize::setup(m, data, asked, seed, source, warnings, settings).map_err(err)
}

/// `hbis diagnose` on arrays: `diagnosis.json`'s text, the same runner's
/// report.
#[pyfunction]
#[pyo3(signature = (t, a, model, noise="white", seed=1, t0=None, effects=Vec::new(), candidates=None, exclude=Vec::new(), source="array"))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    #[pyo3(from_py_with = t_arg)] t: Bound<'_, PyArray1<f64>>,
    #[pyo3(from_py_with = a_arg)] a: Bound<'_, PyArray1<f64>>,
    model: &str,
    noise: &str,
    #[pyo3(from_py_with = seed_arg)] seed: u64,
    t0: Option<f64>,
    effects: Vec<String>,
    candidates: Option<Vec<String>>,
    exclude: Vec<String>,
    source: &str,
) -> PyResult<String> {
    let (t, a) = record_arrays(&t, &a)?;
    let registry = criticism_registry(&effects, candidates, &exclude)?;
    let (model, noise, source) = (model.to_string(), noise.to_string(), source.to_string());
    let run = Run::default();
    let settings = run.map_settings();
    interruptible(py, &run, move || {
        let s = criticism_setup(
            &registry, &t, &a, &model, &noise, seed, t0, &source, &settings,
        )?;
        let d = criticize::diagnose(&registry, &s, &settings).map_err(err)?;
        serde_json::to_string(&d.report).map_err(err)
    })
}

/// `hbis ladder` on arrays: `ladder.json`'s text, the same runner's report;
/// `progress(step_index, model)` after each step (an exception it raises
/// ends the ladder and is raised here).
#[pyfunction]
#[pyo3(signature = (t, a, model, noise="white", seed=1, t0=None, max_steps=6, progress=None, effects=Vec::new(), candidates=None, exclude=Vec::new(), source="array"))]
#[allow(clippy::too_many_arguments)]
fn ladder(
    py: Python<'_>,
    #[pyo3(from_py_with = t_arg)] t: Bound<'_, PyArray1<f64>>,
    #[pyo3(from_py_with = a_arg)] a: Bound<'_, PyArray1<f64>>,
    model: &str,
    noise: &str,
    #[pyo3(from_py_with = seed_arg)] seed: u64,
    t0: Option<f64>,
    #[pyo3(from_py_with = max_steps_arg)] max_steps: usize,
    progress: Option<Py<PyAny>>,
    effects: Vec<String>,
    candidates: Option<Vec<String>>,
    exclude: Vec<String>,
    source: &str,
) -> PyResult<String> {
    check_callable(py, &progress, "progress(step_index, model)")?;
    let (t, a) = record_arrays(&t, &a)?;
    let registry = criticism_registry(&effects, candidates, &exclude)?;
    let (model, noise, source) = (model.to_string(), noise.to_string(), source.to_string());
    let run = Run::default();
    let hook = run.clone();
    let settings = run.map_settings();
    interruptible(py, &run, move || {
        let s = criticism_setup(
            &registry, &t, &a, &model, &noise, seed, t0, &source, &settings,
        )?;
        let mut k = 0usize;
        let mut on_step = |step: &hbis::criticism::Step| {
            hook.check();
            if let Some(cb) = &progress {
                hook.call_back(|py| cb.call1(py, (k, step.model.clone())));
            }
            k += 1;
        };
        let l =
            criticize::ladder(&registry, &s, &settings, max_steps, &mut on_step).map_err(err)?;
        serde_json::to_string(&l.report).map_err(err)
    })
}

/// A synthetic Kanai-Tajimi ground motion (firm soil by default) of
/// `seed`, scaled to `pga` (m/s^2): the ground acceleration at `i dt`.
/// The library refuses more samples than a motion may hold.
#[pyfunction]
#[pyo3(signature = (seed, pga = 0.3 * 9.80665, duration = 40.0, dt = 0.01, f_g = 2.5, zeta_g = 0.6))]
fn kanai_tajimi<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = seed_arg)] seed: u64,
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

/// The parameter sets (rows of `thetas`) and their masses, checked, as
/// the draws of a prediction.
fn checked_draws(
    m: &Model,
    thetas: Vec<Vec<f64>>,
    masses: Option<Vec<f64>>,
    mass: Option<f64>,
) -> PyResult<Vec<hbis::predict::Draw>> {
    let width = m.layout().names().len();
    if let Some(bad) = thetas.iter().position(|t| t.len() != width) {
        return Err(value_error(format!(
            "thetas row {bad}: {} values, the model {} has {width} parameters ({})",
            thetas[bad].len(),
            m.name(),
            m.layout().names().join(", ")
        )));
    }
    let masses = match (mass, masses) {
        (Some(_), Some(_)) => {
            return Err(value_error(
                "mass and masses: give one mass for every set or one per set, not both",
            ))
        }
        (Some(w), None) => {
            check_positive("mass", w)?;
            Some(vec![w; thetas.len()])
        }
        (None, Some(ms)) => {
            if ms.len() != thetas.len() {
                return Err(value_error(format!(
                    "masses: {} values for {} parameter sets",
                    ms.len(),
                    thetas.len()
                )));
            }
            for (i, w) in ms.iter().enumerate() {
                check_positive(&format!("masses[{i}]"), *w)?;
            }
            Some(ms)
        }
        (None, None) => None,
    };
    for (i, t) in thetas.iter().enumerate() {
        m.check(t)
            .map_err(|e| value_error(format!("thetas row {i}: {}", chain(&e))))?;
    }
    let draws: Vec<hbis::predict::Draw> = thetas
        .into_iter()
        .enumerate()
        .map(|(i, theta)| hbis::predict::Draw {
            theta,
            mass: masses.as_ref().map(|ms| ms[i]),
            origin: None,
        })
        .collect();
    Ok(draws)
}

/// Per outcome: peak displacement, residual displacement, peak base shear
/// and peak total acceleration (`Prediction.COLUMNS`).
fn peak_rows(outcomes: &[hbis::predict::DrawOutcome]) -> Array2<f64> {
    let mut rows = Array2::<f64>::zeros((outcomes.len(), 4));
    for (i, o) in outcomes.iter().enumerate() {
        let k = &o.peaks;
        rows[[i, 0]] = k.peak_displacement;
        rows[[i, 1]] = k.residual_displacement;
        rows[[i, 2]] = k.peak_base_shear;
        rows[[i, 3]] = k.peak_total_acceleration;
    }
    rows
}

/// Each parameter set (rows of `thetas`, in the model's order) under the
/// ground acceleration `ag` (m/s^2, step `dt`) from rest, `tail` seconds
/// after: per set `(peak_displacement, residual_displacement,
/// peak_base_shear, peak_total_acceleration)` as an `(n, 4)` array, and
/// the summary as `predict.json` holds it (JSON text). `mass` (t, every
/// set) or `masses` (one per set) give the base shear in kN.
#[pyfunction]
#[pyo3(signature = (model, thetas, dt, ag, tail = 20.0, capacity = None, masses = None, effects = Vec::new(), mass = None))]
#[allow(clippy::too_many_arguments)]
fn predict<'py>(
    py: Python<'py>,
    model: &str,
    thetas: Vec<Vec<f64>>,
    dt: f64,
    #[pyo3(from_py_with = ag_arg)] ag: Bound<'py, PyArray1<f64>>,
    tail: f64,
    capacity: Option<f64>,
    masses: Option<Vec<f64>>,
    effects: Vec<String>,
    mass: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, String)> {
    let m = parse_model(model, &effects)?;
    let draws = checked_draws(&m, thetas, masses, mass)?;
    let ag = values(&ag)?;
    let n_draws = draws.len();
    let run = Run::default();
    let opts = hbis::predict::PredictOptions {
        tail,
        capacity,
        band_points: 0,
        cancel: Some(run.cancel.clone()),
    };
    let p = interruptible(py, &run, move || {
        hbis::predict::predict(&m, &draws, dt, &ag, &opts).map_err(err)
    })?;
    let rows = peak_rows(p.outcomes.as_slice());
    let json = serde_json::json!({
        "draws": n_draws,
        "summary": p.summary,
        "p_exceed_capacity": p.p_exceed_capacity,
        "extrapolation": p.extrapolation,
        "warnings": p.warnings,
    });
    Ok((rows.into_pyarray(py), json.to_string()))
}

/// The seed of motion `j` of the synthetic suite of seed `seed`, as
/// `hbis predict --motions N --seed S` draws them.
#[pyfunction]
fn suite_seed(#[pyo3(from_py_with = seed_arg)] seed: u64, j: usize) -> u64 {
    hbis::data::ground_motion::suite_seed(seed, j)
}

/// The parameter sets paired with a suite of motions `(dt, ag)` (as
/// `hbis predict --motions`; the library's [`run_prediction`]): per pair
/// the four quantities as an `(pairs, 4)` array, the `(draw, motion)`
/// index of each pair, and the report (JSON text). `level` (m/s^2) scales
/// every motion to that PGA first; `pgas` (m/s^2) add the fragility curve
/// of `capacity`.
///
/// [`run_prediction`]: hbis::study::prediction::run_prediction
#[pyfunction]
#[pyo3(signature = (model, thetas, motions, tail = 20.0, capacity = None, masses = None, effects = Vec::new(), pgas = Vec::new(), level = None))]
#[allow(clippy::too_many_arguments)]
#[allow(clippy::type_complexity)]
fn predict_suite<'py>(
    py: Python<'py>,
    model: &str,
    thetas: Vec<Vec<f64>>,
    motions: Vec<(f64, Vec<f64>)>,
    tail: f64,
    capacity: Option<f64>,
    masses: Option<Vec<f64>>,
    effects: Vec<String>,
    pgas: Vec<f64>,
    level: Option<f64>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Vec<(usize, usize)>, String)> {
    use hbis::data::ground_motion::GroundMotion;
    use hbis::study::prediction::{run_prediction, PredictJob};
    let m = parse_model(model, &effects)?;
    let draws = checked_draws(&m, thetas, masses, None)?;
    if let Some(c) = capacity {
        check_positive("capacity", c)?;
    }
    for (i, g) in pgas.iter().enumerate() {
        check_positive(&format!("pga[{i}]"), *g)?;
    }
    let motions: Vec<GroundMotion> = motions
        .into_iter()
        .enumerate()
        .map(|(j, (dt, ag))| {
            let g = GroundMotion {
                dt,
                ag,
                source: format!("motions[{j}]"),
            };
            match level {
                Some(l) => g.scaled_to_pga(l).map_err(err),
                None => Ok(g),
            }
        })
        .collect::<PyResult<_>>()?;
    let run = Run::default();
    let job = PredictJob {
        model: m,
        draws,
        fit: None,
        fit_seed: None,
        params: None,
        motions,
        scale: 1.0,
        fragility_pgas: pgas,
        seed: 0,
        opts: hbis::predict::PredictOptions {
            tail,
            capacity,
            band_points: 0,
            cancel: Some(run.cancel.clone()),
        },
    };
    let n_draws = job.draws.len();
    let n_motions = job.motions.len();
    let out = interruptible(py, &run, move || run_prediction(&job).map_err(err))?;
    let p = &out.prediction;
    let rows = peak_rows(p.outcomes.as_slice());
    let json = serde_json::json!({
        "draws": n_draws,
        "motions": n_motions,
        "pairs": p.pairs.len(),
        "summary": p.summary,
        "p_exceed_capacity": p.p_exceed_capacity,
        "p_exceed_ci": p.exceedance,
        "fragility": out.fragility,
        "extrapolation": p.extrapolation,
        "warnings": p.warnings,
    });
    let pairs = p.pairs.iter().map(|x| (x.draw, x.motion)).collect();
    Ok((rows.into_pyarray(py), pairs, json.to_string()))
}

/// The compiled part of the `hbis` package.
#[pymodule]
fn _hbis(m: &Bound<'_, PyModule>) -> PyResult<()> {
    hbis::parallel::init_pool();
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
    m.add_function(wrap_pyfunction!(suite_seed, m)?)?;
    m.add_function(wrap_pyfunction!(predict_suite, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_class::<FitResult>()?;
    Ok(())
}
