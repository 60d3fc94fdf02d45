//! `hbis diagnose` and `hbis ladder` through the real binary: the documented
//! keys, and errors that exit 2.

use crate::bin;

use bin::{hbis, hbis_with, stderr};

use std::path::Path;

use hbis::model::{ModelSpec, Params};
use rand::{rngs::StdRng, SeedableRng};

/// A Test 7 record of the full model (1.5 % noise).
fn record(dir: &Path) {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(7).unwrap().to_theta(&spec);
    let (syn, _, _) = crate::common::noisy_record(&hbis::model::Model::from(spec), &truth, 77);
    std::fs::write(dir.join("rec.csv"), syn.record.to_csv()).unwrap();
}

#[test]
fn diagnose_writes_the_documented_keys() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let o = hbis(
        d.path(),
        &[
            "diagnose",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+lcfm",
            "--out",
            "dx",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("dx/diagnosis.json")).unwrap())
            .unwrap();
    assert_eq!(v, file);
    assert_eq!(v["model"], "trilinear+lcfm");
    assert!(v["e2"].is_f64() && v["verdict"].is_string());
    for c in v["candidates"].as_array().unwrap() {
        assert!(c["converged"].is_boolean() && c["agreeing"].is_u64(), "{c}");
    }
    let html = std::fs::read_to_string(d.path().join("dx/report.html")).unwrap();
    // The residual, its map, and the missing form's figure when it names
    // terms (here viscous damping is missing).
    let terms = v["missing_form"]["terms"].as_array().unwrap();
    assert!(!terms.is_empty());
    crate::bin::assert_self_contained(&html, 2 + usize::from(!terms.is_empty()));
    assert!(
        html.contains(&escape(v["verdict"].as_str().unwrap())),
        "verdict"
    );
    assert!(
        html.contains(&escape(v["conclusion"].as_str().unwrap())),
        "conclusion"
    );
    assert!(html.contains("<td>viscous</td>"), "candidates table");
    assert!(v["residual"]["dominant_frequency_hz"].is_f64());
    // Screening is for the averaging sensor only (tests/it/sensor.rs).
    assert_eq!(v["screened_out"], serde_json::json!([]));
    let c = v["candidates"].as_array().unwrap();
    assert_eq!(c[0]["effect"], "viscous", "{c:?}");
    for k in [
        "effect",
        "model",
        "e2",
        "delta_bic",
        "delta_log_likelihood",
        "delta_log_evidence",
        "score",
        "supported",
    ] {
        assert!(c[0].get(k).is_some(), "candidate lacks `{k}`");
    }
    assert_eq!(c[0]["model"], "trilinear+lcfm+viscous");
    #[cfg(feature = "figures")]
    for f in ["residual.png", "residual-map.png"] {
        assert!(d.path().join("dx").join(f).exists(), "{f}");
    }
}

/// `diagnose`'s report does not depend on the thread count: its refit
/// starts, Hessians and neighbourhoods are evaluated side by side
/// (`hbis::parallel`, `criticism::ranking`'s multi-start).
#[test]
fn diagnose_is_the_same_on_one_thread_and_on_three() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let args = |out: &'static str| {
        [
            "diagnose",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+lcfm",
            "--candidates",
            "viscous,offset,friction-decay",
            "--out",
            out,
        ]
    };
    let one = hbis_with(d.path(), &args("one"), "1");
    assert!(one.status.success(), "{}", stderr(&one));
    let three = hbis_with(d.path(), &args("three"), "3");
    assert!(three.status.success(), "{}", stderr(&three));
    let read = |p: &str| std::fs::read_to_string(d.path().join(p)).unwrap();
    assert_eq!(read("one/diagnosis.json"), read("three/diagnosis.json"));
}

/// The record of [`record`] held for 0.3 s first, released 2.3 ms before
/// the first moving sample.
fn held_record(dir: &Path) {
    use hbis::model::ForwardModel;
    use rand_distr::{Distribution, Normal};
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(7).unwrap().to_theta(&spec);
    let mut clean = vec![0.0; 2001];
    hbis::model::Model::from(spec)
        .accel_grid_into(&truth, 0.0023, 0.005, &mut clean)
        .unwrap();
    let peak = clean.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    let noise = Normal::new(0.0, 0.015 * peak).unwrap();
    let mut rng = StdRng::seed_from_u64(77);
    let mut text = String::from("t,a\n");
    for i in 0..60 {
        text.push_str(&format!(
            "{},{}\n",
            i as f64 * 0.005,
            noise.sample(&mut rng)
        ));
    }
    for (i, a) in clean.iter().enumerate() {
        let t = 0.3 + i as f64 * 0.005;
        text.push_str(&format!("{t},{}\n", a + noise.sample(&mut rng)));
    }
    std::fs::write(dir.join("rec.csv"), text).unwrap();
}

#[test]
fn ladder_writes_its_steps() {
    let d = tempfile::tempdir().unwrap();
    held_record(d.path());
    let o = hbis(
        d.path(),
        &[
            "ladder",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+lcfm",
            // The keys and the path, not the catalog's ranking (the
            // `search` tests): the damper beside a numerical stand-in for
            // it and an offset.
            "--candidates",
            "viscous,velocity-friction,offset",
            "--out",
            "lx",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let steps = v["steps"].as_array().unwrap();
    assert_eq!(steps[0]["model"], "trilinear+lcfm");
    assert!(steps[0]["added"].is_null());
    assert_eq!(steps[1]["added"], "viscous", "{}", v["paths"]);
    assert_eq!(v["final_model"], "trilinear+lcfm+viscous");
    for s in steps {
        for k in ["model", "added", "e2", "bic", "log_evidence", "lag"] {
            assert!(s.get(k).is_some(), "step lacks `{k}`");
        }
        let lag = s["lag"].as_f64().unwrap();
        assert!((0.0..0.005).contains(&lag), "lag {lag}");
    }
    // The release lies between the held samples and the first moving one
    // (0.3 s); the record is reported with the final model's placement.
    let data = &v["data"];
    assert_eq!(data["t0_source"], "detected");
    let (t0, lag) = (data["t0"].as_f64().unwrap(), data["lag"].as_f64().unwrap());
    assert!((t0 + lag - 0.3).abs() < 1e-9, "t0 {t0} lag {lag}");
    assert_eq!(data["lag"], steps.last().unwrap()["lag"]);
    #[cfg(feature = "figures")]
    for f in ["ladder.png", "step-0.png", "step-1.png"] {
        assert!(d.path().join("lx").join(f).exists(), "{f}");
    }
    // The page: the ladder figure and one figure per step.
    let html = std::fs::read_to_string(d.path().join("lx/report.html")).unwrap();
    crate::bin::assert_self_contained(&html, 1 + steps.len());
    for s in steps {
        let m = s["model"].as_str().unwrap();
        assert!(html.contains(&format!("<td>{m}</td>")), "{m}");
    }
}

fn escape(s: &str) -> String {
    hbis::report::html::escape(s)
}

#[test]
fn bad_models_and_records_exit_2() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let o = hbis(
        d.path(),
        &[
            "diagnose",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+magic",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--model `trilinear+magic`"),
        "{}",
        stderr(&o)
    );
    std::fs::write(d.path().join("bad.csv"), "t,a\n0,1\n0.005,oops\n").unwrap();
    let o = hbis(
        d.path(),
        &["ladder", "--data", "bad.csv", "--model", "bilinear"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("row 3, column `a`"), "{}", stderr(&o));
    // An unknown name in --candidates or --exclude is named, with the
    // known ones, before any fit and before the output folder is made.
    for flag in ["--candidates", "--exclude"] {
        let o = hbis(
            d.path(),
            &[
                "diagnose",
                "--data",
                "rec.csv",
                "--model",
                "bilinear",
                flag,
                "offset,maxwel",
                "--out",
                "never",
            ],
        );
        assert_eq!(o.status.code(), Some(2), "{flag}");
        let err = stderr(&o);
        assert!(err.contains(&format!("{flag} `offset,maxwel`")), "{err}");
        assert!(err.contains("`maxwel`") && err.contains("maxwell"), "{err}");
        assert!(!d.path().join("never").exists(), "{flag}");
    }
}

/// A velocity-dependent friction record with coloured, filtered and
/// quantised sensor noise (the kind of record on which `diagnose` and the
/// ladder's first step once disagreed): `hbis diagnose` and `hbis ladder
/// --max-steps 0`, same seed, report identical numbers, noise choice and
/// conclusion.
#[test]
fn diagnose_and_the_ladder_agree_on_a_coloured_record() {
    use hbis::criticism::calibration::sensor_noise;
    use hbis::model::{ForwardModel, Model};
    let d = tempfile::tempdir().unwrap();
    let model = Model::parse("trilinear+lcfm+viscous+velocity-friction").unwrap();
    let theta = model
        .theta_from_params(
            &Params::table_8_1(5).unwrap(),
            &[("r_mu", 0.4), ("v_t", 0.03)],
        )
        .unwrap();
    let mut clean = vec![0.0; 2001];
    model.accel_into(&theta, 0.005, &mut clean).unwrap();
    let a = sensor_noise(&clean, 0.005, &mut StdRng::seed_from_u64(12));
    let mut text = String::from("t,a\n");
    for (i, v) in a.iter().enumerate() {
        text.push_str(&format!("{},{v}\n", i as f64 * 0.005));
    }
    std::fs::write(d.path().join("rec.csv"), text).unwrap();
    let common = [
        "--data",
        "rec.csv",
        "--model",
        "trilinear+lcfm+viscous",
        "--noise",
        "auto",
        // Two candidates on the numerical engine and one in closed form:
        // the agreement, not the catalog's ranking.
        "--candidates",
        "velocity-friction,friction-decay,offset",
        "--seed",
        "3",
        "--json",
    ];
    let run = |cmd: &[&str]| -> serde_json::Value {
        let args: Vec<&str> = cmd.iter().chain(&common).copied().collect();
        let o = hbis(d.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let diag = run(&["diagnose", "--out", "dx"]);
    let lad = run(&["ladder", "--out", "lx", "--max-steps", "0"]);
    let step = &lad["steps"][0];
    assert_eq!(lad["steps"].as_array().unwrap().len(), 1);
    assert_eq!(diag["noise_choice"], lad["noise_choice"]);
    assert_eq!(diag["noise"], lad["noise"]);
    for k in ["e2", "bic", "log_evidence", "candidates", "conclusion"] {
        assert_eq!(diag[k], step[k], "`{k}` differs");
    }
    assert!(!diag["candidates"].as_array().unwrap().is_empty());
}
