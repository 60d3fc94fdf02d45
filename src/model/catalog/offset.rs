//! A constant accelerometer offset (a zero error of the sensor).
//!
//! # Formula
//! ```text
//! a_record = a + a_off
//! ```

use crate::model::component::{FeatureKind, OutputComponent, ParamSpec};

/// A constant accelerometer offset `a_off` (m/s^2) added to every sample.
#[derive(Debug, Clone, Copy, Default)]
pub struct Offset;

impl OutputComponent for Offset {
    fn name(&self) -> &str {
        "offset"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("a_off", "m/s^2", (-0.2, 0.2), 0.0)
            .symbol("a_off")
            .meaning("constant accelerometer offset")
            .scale(0.005)]
    }
    fn meaning(&self) -> &str {
        "a constant accelerometer offset: the residual has a non-zero mean, also at rest"
    }
    fn targets(&self) -> Vec<FeatureKind> {
        vec![FeatureKind::Offset]
    }

    fn apply(&self, theta: &[f64], _dt: f64, accel: &mut [f64]) {
        for a in accel.iter_mut() {
            *a += theta[0];
        }
    }
}
