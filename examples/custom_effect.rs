//! A physical effect that is not in the catalog, added by a user: a
//! flexible superstructure mode. The accelerometer sits on a structure that
//! is not rigid; its first mode (frequency `fs`, damping `zs`) is excited by
//! the base motion and rings after every friction jump. The recorded
//! acceleration is the base's plus `gamma` times the mode's relative one:
//!
//! ```text
//! q'' + 2 zs ws q' + ws^2 q = -a_base,     a_record = a_base + gamma q''
//! ```
//!
//! Implementing `OutputComponent` is all it takes: the closed-form solver
//! and the inference code are untouched, and once registered the
//! component is parsed, fitted and offered by `diagnose` and the ladder
//! like a built-in one.
//!
//! ```sh
//! cargo run --release --features examples --example custom_effect
//! ```

use std::sync::Arc;

use hbis::criticism::{diagnosis_of, fit_model};
use hbis::data::synthesize;
use hbis::inference::{MapSettings, Noise};
use hbis::model::{Model, OutputComponent, ParamSpec, Params, Registry};
use rand::{rngs::StdRng, SeedableRng};

/// A superstructure mode seen by the accelerometer.
pub struct Superstructure;

impl OutputComponent for Superstructure {
    fn name(&self) -> &str {
        "superstructure"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("fs", "Hz", (1.0, 20.0), 5.0).meaning("frequency of the mode"),
            ParamSpec::new("zs", "-", (0.005, 0.2), 0.05).meaning("damping ratio of the mode"),
            // gamma = 0 switches the mode off.
            ParamSpec::new("gamma", "-", (0.0, 1.0), 0.0)
                .meaning("share of the mode in the record"),
        ]
    }
    fn meaning(&self) -> &str {
        "a flexible superstructure mode: ringing at fs after every friction jump"
    }
    fn apply(&self, theta: &[f64], dt: f64, accel: &mut [f64]) {
        let (w, z, gamma) = (2.0 * std::f64::consts::PI * theta[0], theta[1], theta[2]);
        // RK4 with the base acceleration interpolated linearly, 8 substeps
        // per sample (stable and accurate for w dt/8 well below 1).
        let (mut q, mut p) = (0.0f64, 0.0f64);
        let rhs = |q: f64, p: f64, a: f64| (p, -a - 2.0 * z * w * p - w * w * q);
        let base = accel.to_vec();
        let h = dt / 8.0;
        for i in 0..accel.len() {
            let (_, qdd) = rhs(q, p, base[i]);
            accel[i] = base[i] + gamma * qdd;
            let next = base.get(i + 1).copied().unwrap_or(base[i]);
            for s in 0..8 {
                let a0 = base[i] + (next - base[i]) * s as f64 / 8.0;
                let a1 = base[i] + (next - base[i]) * (s as f64 + 0.5) / 8.0;
                let a2 = base[i] + (next - base[i]) * (s as f64 + 1.0) / 8.0;
                let k1 = rhs(q, p, a0);
                let k2 = rhs(q + 0.5 * h * k1.0, p + 0.5 * h * k1.1, a1);
                let k3 = rhs(q + 0.5 * h * k2.0, p + 0.5 * h * k2.1, a1);
                let k4 = rhs(q + h * k3.0, p + h * k3.1, a2);
                q += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
                p += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
            }
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut registry = Registry::builtin();
    registry.register_output(Arc::new(Superstructure))?;
    let with_mode = registry.parse("trilinear+lcfm+viscous+superstructure")?;
    let truth = with_mode.theta_from_params(
        &Params::table_8_1(5).unwrap(),
        &[("fs", 6.0), ("zs", 0.03), ("gamma", 0.3)],
    )?;
    let mut rng = StdRng::seed_from_u64(8);
    let data = synthesize(&with_mode, &truth, 0.005, 2001, 0.015, &mut rng)?
        .record
        .aligned(None)?;
    let settings = MapSettings::default();
    let rigid = Model::parse("trilinear+lcfm+viscous")?;
    let fit = fit_model(&rigid, &data, Noise::White, None, &settings, 1)?;
    println!(
        "rigid model: e2 = {:.5}\n{}",
        fit.e2,
        diagnosis_of(&rigid, &fit, &data)?.verdict
    );
    // The registry carries the rigid MAP into the flexible model, the mode
    // switched off (gamma = 0).
    let candidate = registry
        .candidates(&rigid, &fit.theta)
        .into_iter()
        .find(|c| c.effect == "superstructure")
        .expect("a registered component is a candidate");
    let flexible = fit_model(
        &with_mode,
        &data,
        Noise::White,
        Some(candidate.start),
        &settings,
        2,
    )?;
    println!(
        "\nwith the superstructure mode: e2 = {:.5}, BIC {:+.1}",
        flexible.e2,
        flexible.bic - fit.bic
    );
    for name in ["fs", "zs", "gamma"] {
        let v = with_mode
            .layout()
            .get(&flexible.theta, name)
            .unwrap_or(f64::NAN);
        println!("  {name} = {v:.4}");
    }
    Ok(())
}
