//! The command line over a user's registry (`hbis::cli::run_from`), in
//! this process: a component only that registry knows is parsed and
//! simulated by `predict`, and the built-in binary refuses the same model.
//! The registry is set once per process, so this file holds the one test
//! that sets it.

use std::process::ExitCode;
use std::sync::Arc;

use hbis::model::{ForceComponent, Forces, Kinematics, ParamSpec, Registry};

use crate::bin::{hbis, stderr};

/// A linear spring beside the bearing, known only to this registry.
struct ExtraSpring;

impl ForceComponent for ExtraSpring {
    fn name(&self) -> &str {
        "extra-spring"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::new("k_x", "1/s^2", (0.0, 20.0), 0.0)]
    }
    fn meaning(&self) -> &str {
        "a linear spring beside the bearing"
    }
    fn piecewise_linear(&self) -> bool {
        false
    }
    fn modify(&self, theta: &[f64], s: &Kinematics, f: &mut Forces) {
        f.extra += theta[0] * s.u;
    }
}

#[test]
fn the_command_line_runs_over_a_users_registry() {
    let dir = tempfile::tempdir().unwrap();
    let params = r#"{"u0": 0.1, "uy": 0.01, "uF0": 0.002, "rF0": 0.0, "zeta0": 0.03,
        "f0": 0.6, "f1": 0.3, "f2": 0.3, "u3": 0.08, "k_x": 2.0}"#;
    std::fs::write(dir.path().join("p.json"), params).unwrap();
    let model = "trilinear+lcfm+viscous+extra-spring";
    // The built-in binary does not know the component.
    let o = hbis(
        dir.path(),
        &[
            "predict",
            "--model",
            model,
            "--params",
            "p.json",
            "--synthetic",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("extra-spring"), "{}", stderr(&o));
    let mut registry = Registry::builtin();
    registry.register_force(Arc::new(ExtraSpring)).unwrap();
    let out = dir.path().join("pred");
    let p = dir.path().join("p.json");
    let args = [
        "hbis",
        "predict",
        "--model",
        model,
        "--params",
        p.to_str().unwrap(),
        "--synthetic",
        "--out",
        out.to_str().unwrap(),
    ];
    let code = hbis::cli::run_from(registry, args);
    assert_eq!(code, ExitCode::SUCCESS);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("predict.json")).unwrap()).unwrap();
    assert_eq!(v["model"], model);
    assert!(v["summary"]["peak_displacement"]["mean"].as_f64().unwrap() > 0.0);
    // Once per process.
    let again = hbis::cli::run_from(Registry::builtin(), ["hbis", "--version"]);
    assert_eq!(again, ExitCode::from(2));
}
