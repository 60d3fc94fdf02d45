//! A force component that is not in the catalog, written by a user: a gap
//! spring (a stopper, a buffer, a moat wall's bumper) that engages once the
//! isolation level has travelled `gap` from its centre:
//!
//! ```text
//! F_gap = k_gap (|u| - gap) sign(u)   for |u| > gap,   0 otherwise
//! ```
//!
//! It changes the equation of motion, so the model runs on the numerical
//! engine; the kinks at `u = +-gap` are declared so the engine steps onto
//! them. Registered, it is parsed, fitted, offered by `diagnose` and added
//! by the ladder like a built-in component. This example makes a record
//! with a gap spring and runs the ladder from a model without it.
//!
//! ```sh
//! cargo run --release --features examples --example custom_force_effect
//! ```

use std::sync::Arc;

use hbis::criticism::ladder;
use hbis::data::{synthesize, Aligned};
use hbis::inference::{MapSettings, Noise};
use hbis::model::{ForceComponent, Forces, Kinematics, Model, ParamSpec, Params, Registry};
use rand::{rngs::StdRng, SeedableRng};

/// A stopper spring beyond `|u| = gap`.
pub struct GapSpring;

impl ForceComponent for GapSpring {
    fn name(&self) -> &str {
        "gap-spring"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            // k_gap = 0 switches it off.
            ParamSpec::new("k_gap", "1/s^2", (0.0, 20.0), 0.0)
                .meaning("stiffness of the stopper per unit mass"),
            ParamSpec::new("gap", "m", (0.01, 0.3), 0.1).meaning("travel before it engages"),
        ]
    }
    fn meaning(&self) -> &str {
        "a stopper spring that engages beyond a travel `gap`"
    }
    fn signature(&self) -> &str {
        "a stiffening beyond a displacement: the largest swings are shorter and turn more sharply"
    }
    fn piecewise_linear(&self) -> bool {
        // Physically piecewise linear, but with breakpoints the closed-form
        // engine does not know: solved numerically.
        false
    }
    fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
        let (k, gap) = (theta[0], theta[1]);
        let over = s.u.abs() - gap;
        if over > 0.0 {
            f.extra += k * over * s.u.signum();
        }
    }
    fn kinks(&self, theta: &[f64], out: &mut Vec<f64>) {
        out.extend([theta[1], -theta[1]]);
    }
}

/// The registry with the gap spring, and a 10 s record at 200 Hz (1.5 %
/// noise) of Test 5 with a stopper 8 cm out, with its noise floor (the
/// `e2` of the truth on it).
pub fn setup(seed: u64) -> Result<(Registry, Aligned, f64), Box<dyn std::error::Error>> {
    let mut registry = Registry::builtin();
    registry.register_force(Arc::new(GapSpring))?;
    let truth_model = registry.parse("trilinear+lcfm+viscous+gap-spring")?;
    let p = Params::table_8_1(5).ok_or("Table 8.1 has Test 5")?;
    let truth = truth_model.theta_from_params(&p, &[("k_gap", 4.0), ("gap", 0.08)])?;
    let mut rng = StdRng::seed_from_u64(seed);
    let syn = synthesize(&truth_model, &truth, 0.005, 2001, 0.015, &mut rng)?;
    let data = syn.record.aligned(None)?;
    let sse: f64 = data
        .a
        .iter()
        .zip(&syn.clean)
        .map(|(a, c)| (a - c).powi(2))
        .sum();
    let floor = sse / data.energy();
    Ok((registry, data, floor))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (registry, data, floor) = setup(5)?;
    let start = Model::parse("trilinear+lcfm+viscous")?;
    let steps = ladder(
        &registry,
        start,
        &data,
        Noise::White,
        &MapSettings::default(),
        1,
        3,
    )?;
    println!("noise floor e2 = {floor:.5}");
    for s in &steps {
        let added = s.added.as_deref().unwrap_or("(start)");
        println!(
            "{added:>14}: {} e2 = {:.5}, BIC {:.1}",
            s.model, s.e2, s.bic
        );
    }
    Ok(())
}
