//! Property tests of the forward model over the parameter bounds: for any
//! parameter vector inside every parameter's declared bounds, every model
//! (closed form, and the numerical engine with the catalog's force
//! components) either returns a finite acceleration record or an error,
//! never a panic and never NaN presented as success.

use hbis::model::{ForwardModel, Model};
use proptest::prelude::*;

fn check(spec: &str, unit: &[f64], dt: f64, n: usize) -> Result<(), TestCaseError> {
    let model = Model::parse(spec).unwrap();
    let theta: Vec<f64> = model
        .params()
        .iter()
        .zip(unit)
        .map(|(p, u)| p.bounds.0 + u * (p.bounds.1 - p.bounds.0))
        .collect();
    let mut out = vec![f64::NAN; n];
    // About half the draws break an ordering (f1 < f0, f2 < f0, u3 > uy)
    // and are refused with a named parameter; the rest must be finite.
    if model.accel_grid_into(&theta, 0.0, dt, &mut out).is_ok() {
        prop_assert!(
            out.iter().all(|v| v.is_finite()),
            "{spec} at {theta:?}: a non-finite sample returned as success"
        );
    }
    Ok(())
}

/// Unit-cube coordinates, mapped onto each parameter's bounds (the ends
/// included: 0 and 1 are drawn with extra weight).
fn unit(d: usize) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(
        prop_oneof![1 => Just(0.0), 1 => Just(1.0), 8 => 0.0f64..=1.0],
        d,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn closed_form_models_never_panic_or_return_nan(
        u in unit(12),
        which in 0usize..6,
        dt in prop_oneof![Just(0.005), Just(0.02), 1e-4f64..0.05],
    ) {
        let spec = [
            "trilinear+lcfm+viscous",
            "trilinear+coulomb",
            "bilinear+lcfm+viscous",
            "bilinear+coulomb+viscous",
            "linear+viscous",
            "trilinear+lcfm+viscous+offset",
        ][which];
        check(spec, &u, dt, (4.0 / dt) as usize)?;
    }
}

proptest! {
    // The numerical engine costs about a millisecond a record: fewer cases.
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn numerical_engine_models_never_panic_or_return_nan(
        u in unit(12),
        which in 0usize..4,
    ) {
        let spec = [
            "trilinear+lcfm+viscous+velocity-friction",
            "trilinear+lcfm+viscous+friction-decay",
            "trilinear+lcfm+viscous+degradation",
            "bilinear+coulomb+viscous+asymmetric-friction",
        ][which];
        check(spec, &u, 0.005, 801)?;
    }
}

/// A grid too long to hold is an error before any allocation, also for a
/// library caller who skipped `data::limits::grid`; its length saturates
/// instead of wrapping to a short grid.
#[test]
fn a_grid_too_long_to_hold_is_refused_not_allocated() {
    use hbis::model::response::grid_len;
    use hbis::model::{ModelSpec, Params, Response};
    assert_eq!(grid_len(1e-300, 1e300), usize::MAX);
    assert_eq!(grid_len(0.01, 1.0), 101);
    let spec: ModelSpec = "trilinear+lcfm+viscous".parse().unwrap();
    let r = Response::simulate(&spec, &Params::table_8_1(5).unwrap(), 10.0).unwrap();
    let err = r.sample_grid(1e-300).unwrap_err().to_string();
    assert!(err.contains("at most 1e7"), "{err}");
    assert_eq!(r.sample_grid(0.01).unwrap().len(), 1001);
}
