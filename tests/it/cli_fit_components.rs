//! `hbis fit` on a model with components beyond the closed-form core:
//! velocity-dependent friction (numerical engine) and an accelerometer
//! offset. It samples a converged posterior and writes the files of any
//! fit, with BIC and the Laplace evidence.

use crate::bin;

use bin::{hbis, stderr};

use hbis::data::synthesize;
use hbis::model::{Model, Params};
use rand::{rngs::StdRng, SeedableRng};

const MODEL: &str = "bilinear+coulomb+velocity-friction+offset";

#[test]
fn fit_samples_a_model_with_velocity_friction_and_an_offset() {
    let dir = tempfile::tempdir().unwrap();
    let model = Model::parse(MODEL).unwrap();
    let truth = model
        .theta_from_params(
            &Params::table_8_1(5).unwrap(),
            &[("r_mu", 0.4), ("v_t", 0.03), ("a_off", 0.02)],
        )
        .unwrap();
    let mut rng = StdRng::seed_from_u64(21);
    let syn = synthesize(&model, &truth, 0.005, 2001, 0.015, &mut rng).unwrap();
    std::fs::write(dir.path().join("rec.csv"), syn.record.to_csv()).unwrap();
    let o = hbis(
        dir.path(),
        &[
            "fit",
            "--data",
            "rec.csv",
            "--model",
            MODEL,
            "--out",
            "out",
            "--seed",
            "3",
            "--ensembles",
            "2",
            "--ess",
            "1000",
            "--evidence",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("out");
    for f in [
        "fit.json",
        "fit.csv",
        "chains/chain-1.csv",
        "chains/chain-2.csv",
        #[cfg(feature = "figures")]
        "fit.png",
        #[cfg(feature = "figures")]
        "corner.png",
        #[cfg(feature = "figures")]
        "trace.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fit.json")).unwrap()).unwrap();
    assert_eq!(v["model"], MODEL);
    let s = &v["sampling"];
    assert_eq!(s["converged"], true, "{s}");
    let rhat = s["rhat"].as_object().unwrap();
    // Every parameter of the model.
    assert_eq!(rhat.len(), model.layout().len(), "{rhat:?}");
    for (name, r) in rhat {
        assert!(r.as_f64().unwrap() <= 1.01, "R-hat of {name}: {r}");
    }
    assert!(v["bic"].as_f64().unwrap().is_finite());
    assert!(v["log_evidence"].as_f64().unwrap().is_finite());
    // The truth's component values lie in their 95 % intervals.
    for (name, t) in [("r_mu", 0.4), ("v_t", 0.03), ("a_off", 0.02)] {
        let p = &v["posterior"][name];
        let (lo, hi) = (p["q025"].as_f64().unwrap(), p["q975"].as_f64().unwrap());
        eprintln!("{name}: truth {t}, 95 % interval [{lo}, {hi}]");
        assert!(lo <= t && t <= hi, "{name}: {t} outside [{lo}, {hi}]");
    }
}

/// A model the registry refuses is bad input: exit code 2 and a message
/// that names the problem, before any computation.
#[test]
fn bad_models_and_noise_are_refused_with_their_reason() {
    let dir = tempfile::tempdir().unwrap();
    let model = Model::parse("trilinear+lcfm+viscous").unwrap();
    let truth = model
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
        .unwrap();
    let mut rng = StdRng::seed_from_u64(2);
    let syn = synthesize(&model, &truth, 0.005, 401, 0.015, &mut rng).unwrap();
    std::fs::write(dir.path().join("rec.csv"), syn.record.to_csv()).unwrap();
    for (cmd, spec, noise, expected) in [
        (
            "fit",
            "trilinear+offset+offset",
            "white",
            "names `offset` twice",
        ),
        (
            "fit",
            "trilinear+lcfm+coulomb",
            "white",
            "names a friction law twice",
        ),
        (
            "fit",
            "bilinear+velocity-friction",
            "white",
            "needs a friction law",
        ),
        ("fit", "trilinear+magic", "white", "registered: linear"),
        (
            "diagnose",
            "trilinear+friction-decay",
            "white",
            "needs a friction law",
        ),
        (
            "diagnose",
            "trilinear+lcfm",
            "pink",
            "expected `white`, `ar1` or `auto`",
        ),
        (
            "ladder",
            "trilinear+lcfm",
            "red",
            "expected `white`, `ar1` or `auto`",
        ),
    ] {
        let o = hbis(
            dir.path(),
            &[
                cmd, "--data", "rec.csv", "--model", spec, "--noise", noise, "--out", "o",
            ],
        );
        assert_eq!(o.status.code(), Some(2), "{cmd} {spec}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(expected),
            "{cmd} {spec}: {}",
            stderr(&o)
        );
        assert!(!dir.path().join("o").exists(), "{cmd} {spec} wrote output");
    }
}
