//! Could a gradient method refit a numerical candidate from its warm
//! start (issue 36, item 2), in far fewer evaluations than the ranking's
//! local CMA-ES search and polish?
//!
//! On calibration records (`criticism::calibration`: a hidden
//! `velocity-friction`, `degradation` or `friction-decay`, and a white
//! null; 12 s at 200 Hz), the start model is fitted as `diagnose` fits it
//! (the release placed, then [`start_fit`]), and each numerical candidate
//! is refitted from its warm start (the current MAP, the new component at
//! its neutral value) twice: by [`fit_model`] with the ranking's budget for
//! the numerical engine, and by Levenberg-Marquardt on the residuals in
//! the unit box of the priors (log scale where the search uses one), with
//! a two-sided finite-difference Jacobian. Per refit it prints both
//! searches' evaluations, times and the log-likelihood of LM's end less
//! CMA-ES's (white noise, `sigma` profiled: `-n/2 ln(S_lm / S_cmaes)`);
//! then the count of refits where LM ended within 0.1 nats of CMA-ES or
//! above it, with its Clopper-Pearson 95 % interval.
//!
//! ```sh
//! cargo run --release --features examples --example lm_refit -- 443841 4 [averaging [spread]]
//! ```
//! Arguments: first seed, records per kind, `averaging` to make and
//! fit every record with the averaging sensor (or `instant`), and `spread`
//! to run LM also from the ranking's spread start (the new parameters
//! mid-range) and keep the better end. Record `j` of kind `k` has
//! seed `1000 first + 4 j + k`.
//!
//! Not used by the library: a measurement (docs/criticism.md, "A gradient
//! refit from the warm start", 2026-12-06).

use hbis::criticism::calibration::{make_record, Kind, Sensor};
use hbis::criticism::ranking::{start_fit, NUMERIC_BUDGET};
use hbis::criticism::{fit_model, place_release};
use hbis::data::Aligned;
use hbis::inference::map::log_scaled;
use hbis::inference::proportion::clopper_pearson;
use hbis::inference::{MapSettings, Noise, Polish, Posterior};
use hbis::model::{Model, Registry};
use nalgebra::{DMatrix, DVector};
use std::time::Instant;

/// Finite-difference step in the unit box.
const H: f64 = 1e-6;

/// LM stops after two accepted steps in a row that gain less than this
/// (nats), or when no step is accepted.
const GAIN_TOL: f64 = 1e-3;

/// The priors' box, mapped to `[0, 1]` per parameter.
struct UnitBox(Vec<(f64, f64)>);

impl UnitBox {
    fn to_x(&self, z: &[f64]) -> Vec<f64> {
        z.iter()
            .zip(&self.0)
            .map(|(&z, &(lo, hi))| {
                let z = z.clamp(0.0, 1.0);
                if log_scaled(lo, hi) {
                    lo * (hi / lo).powf(z)
                } else {
                    lo + z * (hi - lo)
                }
            })
            .collect()
    }
    fn to_z(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(&self.0)
            .map(|(&x, &(lo, hi))| {
                if log_scaled(lo, hi) {
                    (x / lo).ln() / (hi / lo).ln()
                } else {
                    (x - lo) / (hi - lo)
                }
            })
            .collect()
    }
}

/// The residuals (record less model) at `z`, or `None` where the model
/// refuses the parameters.
struct Residuals<'a> {
    model: &'a Model,
    data: &'a Aligned,
    unit: UnitBox,
    buf: Vec<f64>,
    evals: usize,
}

impl Residuals<'_> {
    fn at(&mut self, z: &[f64], out: &mut Vec<f64>) -> bool {
        self.evals += 1;
        let x = self.unit.to_x(z);
        if self
            .data
            .model_accel_into(self.model, &x, &mut self.buf)
            .is_err()
        {
            return false;
        }
        out.clear();
        out.extend(self.data.a.iter().zip(&self.buf).map(|(a, m)| a - m));
        out.iter().all(|v| v.is_finite())
    }

    /// Column `k` of the Jacobian at `z` (residuals `r`) from two
    /// differences: `+-H` inside the box, `H` and `2H` inward at a bound.
    /// Where a difference crosses a jump of the reading (a reversal past a
    /// sample instant) it is far from the other, and the smaller is kept;
    /// where both cross the same jump (the `H` one twice the `2H` one),
    /// the sample gets no slope.
    fn column(&mut self, z: &[f64], r: &[f64], k: usize, col: &mut [f64]) {
        let (h1, h2) = if z[k] + H > 1.0 {
            (-H, -2.0 * H)
        } else if z[k] - H < 0.0 {
            (H, 2.0 * H)
        } else {
            (H, -H)
        };
        let (mut r1, mut r2) = (Vec::new(), Vec::new());
        let mut zz = z.to_vec();
        zz[k] = z[k] + h1;
        let ok1 = self.at(&zz, &mut r1);
        zz[k] = z[k] + h2;
        let ok2 = self.at(&zz, &mut r2);
        let one_sided = (h1 / h2) > 0.0;
        for i in 0..col.len() {
            let d1 = if ok1 { (r1[i] - r[i]) / h1 } else { f64::NAN };
            let d2 = if ok2 { (r2[i] - r[i]) / h2 } else { f64::NAN };
            col[i] = match (d1.is_finite(), d2.is_finite()) {
                (true, true) => {
                    if one_sided && (1.8..2.2).contains(&(d1 / d2).abs()) {
                        0.0
                    } else if (d1 - d2).abs() > 0.5 * d1.abs().max(d2.abs()) {
                        if d1.abs() < d2.abs() {
                            d1
                        } else {
                            d2
                        }
                    } else {
                        0.5 * (d1 + d2)
                    }
                }
                (true, false) => d1,
                (false, true) => d2,
                _ => 0.0,
            };
        }
    }
}

/// Levenberg-Marquardt (Marquardt's diagonal scaling, Nielsen's damping
/// update) from `start`: the end's sum of squares and the evaluations.
fn levenberg_marquardt(model: &Model, data: &Aligned, start: &[f64]) -> (f64, usize) {
    let unit = UnitBox(Posterior::layout_for(model, Noise::White).bounds());
    let mut z = unit.to_z(start);
    let mut res = Residuals {
        model,
        data,
        unit,
        buf: vec![0.0; data.a.len()],
        evals: 0,
    };
    let (n, p) = (data.a.len(), start.len());
    let mut r = Vec::new();
    assert!(res.at(&z, &mut r), "the warm start is solvable");
    let sse = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let mut s = sse(&r);
    let (mut lambda, mut nu, mut small) = (1e-3, 2.0, 0);
    let mut trial = Vec::new();
    let mut j = DMatrix::<f64>::zeros(n, p);
    for _ in 0..60 {
        for k in 0..p {
            let mut col = vec![0.0; n];
            res.column(&z, &r, k, &mut col);
            j.set_column(k, &DVector::from_vec(col));
        }
        let rv = DVector::from_column_slice(&r);
        let a = j.transpose() * &j;
        let g = j.transpose() * &rv;
        let top = (0..p).map(|k| a[(k, k)]).fold(0.0, f64::max);
        let mut accepted = None;
        for _ in 0..12 {
            let mut m = a.clone();
            for k in 0..p {
                m[(k, k)] += lambda * a[(k, k)].max(1e-9 * top);
            }
            let Some(ch) = m.cholesky() else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let step = ch.solve(&(-&g));
            let zt: Vec<f64> = z
                .iter()
                .zip(step.iter())
                .map(|(z, d)| (z + d).clamp(0.0, 1.0))
                .collect();
            let dz = DVector::from_iterator(p, zt.iter().zip(&z).map(|(a, b)| a - b));
            let predicted = (&rv + &j * &dz).norm_squared();
            if res.at(&zt, &mut trial) && sse(&trial) < s {
                let st = sse(&trial);
                let rho = (s - st) / (s - predicted).max(f64::MIN_POSITIVE);
                accepted = Some(0.5 * n as f64 * (s / st).ln());
                z = zt;
                std::mem::swap(&mut r, &mut trial);
                s = st;
                lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                break;
            }
            lambda *= nu;
            nu *= 2.0;
        }
        match accepted {
            None => break,
            Some(gain) if gain < GAIN_TOL => {
                small += 1;
                if small >= 2 {
                    break;
                }
            }
            Some(_) => small = 0,
        }
    }
    (s, res.evals)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let first: u64 = args.first().map_or(Ok(443841), |s| s.parse())?;
    let per_kind: u64 = args.get(1).map_or(Ok(4), |s| s.parse())?;
    let sensor = match args.get(2).map(String::as_str) {
        None | Some("instant") => Sensor::Instant,
        Some("averaging") => Sensor::Averaging,
        Some(other) => return Err(format!("{other}: expected instant or averaging").into()),
    };
    let spread = args.get(3).is_some_and(|a| a == "spread");
    println!("seed {first}, {per_kind} records per kind, sensor {sensor:?}, spread start {spread}");
    let registry = Registry::builtin();
    let settings = MapSettings::default();
    let numeric = settings
        .clone()
        .with_max_evals(NUMERIC_BUDGET)?
        .with_polish(Some(Polish::default().with_max_iters(300)?))?;
    let kinds = [
        Kind::Hidden(0),
        Kind::Hidden(2),
        Kind::Hidden(4),
        Kind::NullWhite,
    ];
    let (mut reached, mut total) = (0usize, 0usize);
    let (mut ev_cma, mut ev_lm, mut t_cma, mut t_lm) = (Vec::new(), Vec::new(), 0.0, 0.0);
    for j in 0..per_kind {
        for (k, &kind) in kinds.iter().enumerate() {
            let seed = 1000 * first + 4 * j + k as u64;
            let mut rec = make_record(&registry, kind, sensor, seed)?;
            rec.data = place_release(&rec.start, rec.data, &settings, seed)?;
            let fit = start_fit(&rec.start, &rec.data, Noise::White, &settings, seed)?;
            let theta = fit.model_theta(&rec.start).to_vec();
            let n = rec.data.a.len() as f64;
            for c in registry.candidates(&rec.start, &theta) {
                if c.model.closed_form() {
                    continue;
                }
                let clock = Instant::now();
                let cma = fit_model(
                    &c.model,
                    &rec.data,
                    Noise::White,
                    Some(c.start.clone()),
                    &numeric,
                    seed,
                )?;
                let tc = clock.elapsed().as_secs_f64();
                let clock = Instant::now();
                let (mut s_lm, mut evals) = levenberg_marquardt(&c.model, &rec.data, &c.start);
                if spread {
                    // Also from the ranking's spread start: the new
                    // parameters mid-range (on the search's scale).
                    let names = Posterior::names_for(&c.model, Noise::White);
                    let old = Posterior::names_for(&rec.start, Noise::White);
                    let unit = UnitBox(Posterior::layout_for(&c.model, Noise::White).bounds());
                    let mut z = unit.to_z(&c.start);
                    for (k, name) in names.iter().enumerate() {
                        if !old.contains(name) {
                            z[k] = 0.5;
                        }
                    }
                    let (s2, e2) = levenberg_marquardt(&c.model, &rec.data, &unit.to_x(&z));
                    s_lm = s_lm.min(s2);
                    evals += e2;
                }
                let tl = clock.elapsed().as_secs_f64();
                let s_cma = cma.e2 * rec.data.energy();
                let d = -0.5 * n * (s_lm / s_cma).ln();
                total += 1;
                reached += usize::from(d >= -0.1);
                ev_cma.push(cma.evaluations as f64);
                ev_lm.push(evals as f64);
                t_cma += tc;
                t_lm += tl;
                println!(
                    "{kind:?} seed {seed} {:>18}: CMA-ES {:>6} evaluations {tc:.2} s (gain {:+.1}) | LM {evals:>5} evaluations {tl:.2} s | LM less CMA-ES {d:+.3} nats",
                    c.effect,
                    cma.evaluations,
                    cma.log_likelihood - fit.log_likelihood,
                );
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (lo, hi) = clopper_pearson(reached as f64, total as f64, 0.95);
    println!(
        "LM within 0.1 nats of CMA-ES or above: {reached} of {total} ({:.1}-{:.1} %); median evaluations CMA-ES {:.0}, LM {:.0}; time CMA-ES {t_cma:.1} s, LM {t_lm:.1} s",
        100.0 * lo,
        100.0 * hi,
        median(&mut ev_cma),
        median(&mut ev_lm),
    );
    Ok(())
}
