//! The real `hbis` binary, run in temporary folders.

use crate::bin;

use bin::{hbis, stderr};

use std::path::Path;

const TEST5: &str = r#"{"u0": 0.1166, "uy": 0.01167, "uF0": 0.00234, "rF0": 0.00235, "zeta0": 0.02256,
 "f0": 0.53979, "f1": 0.41723, "f2": 0.37477, "u3": 0.08252}"#;

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

#[test]
fn simulate_writes_the_documented_csv() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    let o = hbis(
        d.path(),
        &[
            "simulate",
            "--model",
            "trilinear+lcfm+viscous",
            "--params",
            "p.json",
            "--dt",
            "0.005",
            "--duration",
            "10",
            "--out",
            "r.csv",
            "--phases",
            "ph.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(d.path().join("r.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,u,v,a,f_spring,f_friction,f_damper,phase"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2001);
    assert_eq!(rows[0][0], "0.0");
    assert_eq!(rows[0][1], "0.1166");
    // a = -(f_spring + f_friction + f_damper) on every row.
    for r in &rows {
        let x: Vec<f64> = r[..7].iter().map(|s| s.parse().unwrap()).collect();
        assert!((x[3] + x[4] + x[5] + x[6]).abs() < 1e-12, "{r:?}");
    }
    assert_eq!(rows[0][7], "elastic");
    assert_eq!(rows[2000][7], "rest");
    assert!(
        stderr(&o).contains("residual displacement: 3.04 mm"),
        "{}",
        stderr(&o)
    );
    let phases = std::fs::read_to_string(d.path().join("ph.csv")).unwrap();
    assert!(phases.starts_with("kind,t_start,t_end,u_start,u_end,direction\nelastic,0.0,"));
}

#[test]
fn simulate_without_out_writes_csv_to_stdout() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", r#"{"u0": 0.05, "f0": 0.5}"#);
    let o = hbis(
        d.path(),
        &[
            "simulate",
            "--model",
            "linear",
            "--params",
            "p.json",
            "--dt",
            "0.1",
            "--duration",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(out.lines().count(), 12);
}

#[test]
fn bad_input_exits_2_with_one_line_naming_the_field() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    write(
        d.path(),
        "unknown.json",
        r#"{"u0": 0.1, "f0": 0.5, "fz": 1}"#,
    );
    write(d.path(), "missing.json", r#"{"u0": 0.1}"#);
    write(d.path(), "invalid.json", &TEST5.replace("0.08252", "0.005"));
    write(d.path(), "text.json", r#"{"u0": "big", "f0": 0.5}"#);
    write(d.path(), "broken.json", r#"{"u0": 0.1,"#);
    let sim = |params: &str, model: &str, dt: &str| {
        hbis(
            d.path(),
            &[
                "simulate",
                "--model",
                model,
                "--params",
                params,
                "--dt",
                dt,
                "--duration",
                "10",
                "--out",
                "x.csv",
            ],
        )
    };
    let full = "trilinear+lcfm+viscous";
    let cases = [
        (sim("unknown.json", "linear", "0.01"), "fz"),
        (
            sim("missing.json", "linear", "0.01"),
            "missing parameter `f0`",
        ),
        (sim("invalid.json", full, "0.01"), "u3"),
        (sim("text.json", "linear", "0.01"), "u0"),
        (sim("broken.json", "linear", "0.01"), "broken.json"),
        (sim("nowhere.json", "linear", "0.01"), "nowhere.json"),
        (sim("p.json", full, "0"), "dt"),
        (sim("p.json", full, "-0.5"), "dt"),
        (sim("p.json", "trilinear+magic", "0.01"), "magic"),
        (
            sim("p.json", "bilinear+coulomb", "0.01"),
            "not used by model",
        ),
    ];
    for (o, needle) in cases {
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{needle}: {e}");
        assert!(e.contains(needle), "`{needle}` not in: {e}");
        assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    assert!(
        !d.path().join("x.csv").exists(),
        "nothing written on bad input"
    );
}

#[test]
fn convert_prints_table_8_2_quantities() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    let o = hbis(
        d.path(),
        &[
            "convert",
            "--params",
            "p.json",
            "--released-force",
            "1180",
            "--static-friction",
            "100",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let want = [
        ("m", 1333.0),
        ("k0", 15332.0),
        ("k1", 9160.0),
        ("k2", 7390.0),
        ("kF", 36.0),
        ("c", 204.0),
    ];
    for (k, w) in want {
        let g = v[k].as_f64().unwrap_or_else(|| panic!("key {k} in {v}"));
        assert!((g - w).abs() <= (1e-3 * w).max(1.0), "{k}: {g} vs {w}");
    }
    let o = hbis(
        d.path(),
        &[
            "convert",
            "--params",
            "p.json",
            "--released-force",
            "90",
            "--static-friction",
            "100",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("released force"));
}

/// `convert` takes any registry model: eq. 8.1 reads the core, so a model
/// with a Maxwell element beside it converts to the core's numbers; a model
/// whose spring law is replaced is refused, naming the component.
#[test]
fn convert_takes_any_registry_model() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    let with_maxwell = TEST5.replace('}', r#", "r_m": 0.2, "tau_m": 0.5}"#);
    write(d.path(), "pm.json", &with_maxwell);
    let forces = [
        "--released-force",
        "1180",
        "--static-friction",
        "100",
        "--json",
    ];
    let run = |model: &str, params: &str| {
        let mut args = vec!["convert", "--model", model, "--params", params];
        args.extend(forces);
        hbis(d.path(), &args)
    };
    let core = run("trilinear+lcfm+viscous", "p.json");
    let more = run("trilinear+lcfm+viscous+maxwell", "pm.json");
    assert!(core.status.success(), "{}", stderr(&core));
    assert!(more.status.success(), "{}", stderr(&more));
    assert_eq!(core.stdout, more.stdout);
    // The Maxwell parameters are the model's: leaving them out is named.
    let o = run("trilinear+lcfm+viscous+maxwell", "p.json");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("r_m"), "{}", stderr(&o));
    let o = run("bouc-wen+lcfm+viscous", "p.json");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("bouc-wen"), "{}", stderr(&o));
}

#[test]
fn demo_runs_on_the_embedded_default() {
    let d = tempfile::tempdir().unwrap();
    let o = hbis(d.path(), &["demo", "--out", "demo"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.contains("residual displacement: 3.04 mm"), "{out}");
    assert!(out.contains("m  =     1333.1 t"), "{out}");
    assert!(d.path().join("demo/test5.csv").exists());
    ladder_recovers_the_full_model(&d.path().join("demo/ladder/ladder.json"), &out);
    earthquake_quantiles_match_a_brute_force_loop(&d.path().join("demo/predict"));
    if cfg!(feature = "figures") {
        let png = std::fs::metadata(d.path().join("demo/test5.png")).unwrap();
        assert!(png.len() > 10_000);
    }
}

/// The demo's ladder (a Test 8 record of the full model, 1.5 % noise, from
/// `bilinear+coulomb`, every catalog effect a candidate) recovers the model
/// that made the record, with `e2` and BIC falling at every step, ends
/// within 15 % of the noise floor the demo prints, and supports nothing
/// more.
fn ladder_recovers_the_full_model(path: &Path, stdout: &str) {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let steps = v["steps"].as_array().unwrap();
    let models: Vec<&str> = steps.iter().map(|s| s["model"].as_str().unwrap()).collect();
    assert_eq!(v["final_model"], "trilinear+lcfm+viscous", "{models:?}");
    for w in steps.windows(2) {
        for k in ["e2", "bic"] {
            let (a, b) = (w[0][k].as_f64().unwrap(), w[1][k].as_f64().unwrap());
            assert!(b < a, "{k} rose from {a} to {b}: {models:?}");
        }
    }
    // The criticism section's floor (the fit section prints its own).
    let floor: f64 = stdout
        .split("Model criticism:")
        .nth(1)
        .and_then(|r| r.split("noise floor e2 = ").nth(1))
        .and_then(|r| r.split(')').next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no noise floor in {stdout}"));
    let last = steps.last().unwrap();
    let e2 = last["e2"].as_f64().unwrap();
    assert!(e2 <= 1.15 * floor, "e2 {e2} vs floor {floor}");
    for c in last["candidates"].as_array().unwrap() {
        assert_eq!(c["supported"], false, "{}", c["effect"]);
    }
}

/// The demo's `hbis predict` step against a brute-force loop over the same
/// draws (from its draws.csv) through the numerical engine: per draw and
/// in the quantiles of predict.json.
fn earthquake_quantiles_match_a_brute_force_loop(dir: &Path) {
    use hbis::data::ground_motion::KanaiTajimi;
    use hbis::model::forced::Excitation;
    use rayon::prelude::*;

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("predict.json")).unwrap()).unwrap();
    for key in [
        "peak_displacement",
        "residual_displacement",
        "peak_base_shear",
        "peak_total_acceleration",
    ] {
        for s in ["mean", "sd", "q05", "q50", "q95"] {
            assert!(json["summary"][key][s].is_f64(), "summary.{key}.{s}");
        }
    }
    assert!(json["p_exceed_capacity"].is_f64() && json["warnings"].is_array());
    let csv = std::fs::read_to_string(dir.join("draws.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let model = hbis::model::Registry::builtin()
        .parse(json["model"].as_str().unwrap())
        .unwrap();
    let names = hbis::model::ForwardModel::param_names(&model);
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let idx: Vec<usize> = names.iter().map(|n| col(n)).collect();
    let peak = col("peak_displacement");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), json["draws"].as_u64().unwrap() as usize);
    // The demo's motion: the default Kanai-Tajimi motion of seed 2026.
    let motion = KanaiTajimi::default().generate(2026).unwrap();
    let ex = Excitation::new(motion.dt, &motion.ag, 20.0).unwrap();
    let brute: Vec<f64> = rows
        .par_iter()
        .map(|r| {
            let theta: Vec<f64> = idx.iter().map(|&k| r[k]).collect();
            model
                .forced_numerically(&theta, &ex, 1e-12, &mut ())
                .unwrap()
                .peak_displacement
        })
        .collect();
    for (r, b) in rows.iter().zip(&brute) {
        assert!(
            (r[peak] - b).abs() < 1e-7,
            "draw {}: {} vs {b}",
            r[0],
            r[peak]
        );
    }
    let mut sorted = brute.clone();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let h = (sorted.len() - 1) as f64 * p;
        let lo = h.floor() as usize;
        let hi = (lo + 1).min(sorted.len() - 1);
        sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
    };
    for (name, p) in [("q05", 0.05), ("q50", 0.5), ("q95", 0.95)] {
        let v = json["summary"]["peak_displacement"][name].as_f64().unwrap();
        assert!((v - q(p)).abs() < 1e-7, "{name}: {v} vs {}", q(p));
    }
    for f in ["response.png", "peak-displacement.png", "band.csv"] {
        if f.ends_with(".png") && !cfg!(feature = "figures") {
            continue;
        }
        assert!(std::fs::metadata(dir.join(f)).unwrap().len() > 1000, "{f}");
    }
}

/// `hbis simulate` on a model beyond the closed-form core (a component with
/// memory): `t,u,v,a,phase`, `a` equal to the library's acceleration; the
/// closed-form-only outputs are refused by name.
#[test]
fn simulate_runs_any_registry_model() {
    use hbis::model::{ForwardModel, Params, Registry};
    let d = tempfile::tempdir().unwrap();
    let model = Registry::builtin()
        .parse("trilinear+lcfm+viscous+maxwell")
        .unwrap();
    let p = Params::table_8_1(5).unwrap();
    let theta = model
        .theta_from_params(&p, &[("r_m", 0.2), ("tau_m", 0.4)])
        .unwrap();
    let json: serde_json::Map<String, serde_json::Value> = model
        .param_names()
        .into_iter()
        .zip(&theta)
        .map(|(n, v)| (n, serde_json::json!(v)))
        .collect();
    std::fs::write(
        d.path().join("p.json"),
        serde_json::to_string(&json).unwrap(),
    )
    .unwrap();
    let args = [
        "simulate",
        "--model",
        "trilinear+lcfm+viscous+maxwell",
        "--params",
        "p.json",
        "--dt",
        "0.01",
        "--duration",
        "3",
    ];
    let o = hbis(d.path(), &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,u,v,a,phase"));
    let a: Vec<f64> = lines
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    let mut expected = vec![0.0; 301];
    model.accel_into(&theta, 0.01, &mut expected).unwrap();
    assert_eq!(a, expected);
    let o = hbis(d.path(), &[&args[..], &["--phases", "ph.csv"]].concat());
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--phases"), "{}", stderr(&o));
}
