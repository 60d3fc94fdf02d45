//! `hbis predict` through the real binary: one parameter set, motions from
//! files, the documented keys, and bad input refused with exit code 2.

use crate::bin;

use bin::{hbis, stderr};

use std::path::Path;

use hbis::model::forced::Excitation;
use hbis::model::numeric::NumericSystem;
use hbis::model::{ModelSpec, Params, System};

const TEST5: &str = r#"{"u0": 0.1166, "uy": 0.01167, "uF0": 0.00234, "rF0": 0.00235, "zeta0": 0.02256,
 "f0": 0.53979, "f1": 0.41723, "f2": 0.37477, "u3": 0.08252}"#;

/// One draw of Test 5 as a CmdStan-style chain.
const CHAIN: &str = "# a comment\nlp__,accept_stat__,u0,uy,uF0,rF0,zeta0,f0,f1,f2,u3\n0,0,0.1166,0.01167,0.00234,0.00235,0.02256,0.53979,0.41723,0.37477,0.08252\n";

/// A fit folder as a finished `hbis fit` leaves it: `fit.json`, the chains
/// and the manifest listing them.
fn finished_fit(dir: &Path, fit_json: &str, chains: &[&str]) {
    let mut out = hbis::report::outdir::OutDir::open(dir, &[], "fit").unwrap();
    out.write("fit.json", fit_json.as_bytes()).unwrap();
    for (i, c) in chains.iter().enumerate() {
        out.write(&format!("chains/chain-{}.csv", i + 1), c.as_bytes())
            .unwrap();
    }
    out.finish("fit", 1, "trilinear+lcfm+viscous", None)
        .unwrap();
}

/// Runs the binary in `dir`, expects success and parses its standard
/// output (`--json`).
fn run_json(dir: &Path, args: &[&str]) -> serde_json::Value {
    let o = hbis(dir, args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

/// An AT2 file of a 2 Hz sine pulse train, 10 s at 100 Hz, in g.
fn at2() -> String {
    let n = 1001;
    let mut s = String::from(
        "PEER NGA STRONG MOTION DATABASE RECORD\\nsynthetic sine, hbis test\\nACCELERATION TIME SERIES IN UNITS OF G\\n",
    )
    .replace("\\n", "\n");
    s += &format!("NPTS= {n}, DT= .0100 SEC\n");
    for i in 0..n {
        let t = i as f64 * 0.01;
        let a = if t < 5.0 {
            0.2 * (2.0 * std::f64::consts::PI * 0.5 * t).sin()
        } else {
            0.0
        };
        s += &format!("{a:.7E}");
        s += if i % 5 == 4 { "\n" } else { " " };
    }
    s + "\n"
}

#[test]
fn one_parameter_set_under_an_at2_motion_and_the_same_in_columns() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    write(d.path(), "gm.AT2", &at2());
    let j = run_json(
        d.path(),
        &[
            "predict",
            "--model",
            "trilinear+lcfm+viscous",
            "--params",
            "p.json",
            "--motion",
            "gm.AT2",
            "--capacity",
            "0.05",
            "--tail",
            "10",
            "--json",
            "--out",
            "pred",
        ],
    );
    assert_eq!(j["draws"], 1);
    for key in [
        "peak_displacement",
        "residual_displacement",
        "peak_base_shear",
        "peak_total_acceleration",
    ] {
        let s = &j["summary"][key];
        let v = s["mean"].as_f64().unwrap();
        assert!(v.is_finite() && v >= 0.0, "{key}");
        assert_eq!(s["q05"], s["mean"], "{key}");
        assert_eq!(s["q50"], s["mean"]);
        assert_eq!(s["q95"], s["mean"]);
        assert_eq!(s["sd"], 0.0);
    }
    let peak = j["summary"]["peak_displacement"]["mean"].as_f64().unwrap();
    // The peak computed independently: the numerical engine (Dormand-Prince
    // at 1e-12) on the same motion, read from the file's own digits.
    let ag: Vec<f64> = at2()
        .lines()
        .skip(4)
        .flat_map(|l| l.split_whitespace().map(|x| x.parse::<f64>().unwrap()))
        .map(|g| g * 9.80665)
        .collect();
    let ex = Excitation::new(0.01, &ag, 10.0).unwrap();
    let system = System::new(&ModelSpec::FULL, &Params::table_8_1(5).unwrap());
    let mut u = Vec::new();
    let independent = NumericSystem::with_terms(system, &[])
        .forced(&ex, 1e-12, &mut u)
        .unwrap()
        .peak_displacement;
    assert!((peak - independent).abs() < 1e-6, "{peak} {independent}");
    // p_exceed against that peak, with capacities just either side of it.
    let p = j["p_exceed_capacity"].as_f64().unwrap();
    assert_eq!(p, if independent > 0.05 { 1.0 } else { 0.0 });
    for (capacity, expected) in [(0.999 * independent, 1.0), (1.001 * independent, 0.0)] {
        let c = capacity.to_string();
        let v = run_json(
            d.path(),
            &[
                "predict",
                "--model",
                "trilinear+lcfm+viscous",
                "--params",
                "p.json",
                "--motion",
                "gm.AT2",
                "--capacity",
                &c,
                "--tail",
                "10",
                "--json",
                "--out",
                "pred-c",
            ],
        );
        assert_eq!(
            v["p_exceed_capacity"].as_f64(),
            Some(expected),
            "capacity {c}"
        );
    }
    assert!((j["motion"]["pga"].as_f64().unwrap() - 0.2 * 9.80665).abs() < 1e-3);
    assert!(d.path().join("pred/draws.csv").exists());

    // The same motion as two columns in m/s^2, scaled back from g.
    let mut cols = String::from("t,ag\n");
    let text = at2();
    let values: Vec<f64> = text
        .lines()
        .skip(4)
        .flat_map(|l| l.split_whitespace().map(|x| x.parse::<f64>().unwrap()))
        .collect();
    for (i, a) in values.iter().enumerate() {
        cols += &format!("{},{}\n", i as f64 * 0.01, a);
    }
    write(d.path(), "gm.csv", &cols);
    let k = run_json(
        d.path(),
        &[
            "predict",
            "--model",
            "trilinear+lcfm+viscous",
            "--params",
            "p.json",
            "--motion",
            "gm.csv",
            "--motion-units",
            "m/s2",
            "--scale",
            "9.80665",
            "--tail",
            "10",
            "--json",
            "--out",
            "pred2",
        ],
    );
    let peak2 = k["summary"]["peak_displacement"]["mean"].as_f64().unwrap();
    assert!(
        (peak - peak2).abs() < 1e-12 * peak.max(1.0),
        "{peak} {peak2}"
    );
}

#[test]
fn bad_predict_input_exits_2_naming_what_is_wrong() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    write(d.path(), "gm.csv", "t,ag\n0,0.1\n0.01,0.2\n0.02,0.1\n");
    write(d.path(), "bad.csv", "t,ag\n0,0.1\n0.01,zz\n");
    write(d.path(), "extra.json", &TEST5.replace("\"u3\"", "\"u4\""));
    write(d.path(), "twice.json", &TEST5.replace("\"uy\"", "\"u0\""));
    write(d.path(), "zero.json", &TEST5.replace("0.1166", "0"));
    write(d.path(), "stiff.json", &TEST5.replace("0.53979", "1e100"));
    let good = at2();
    write(
        d.path(),
        "npts.AT2",
        &good.replace("NPTS= 1001", "NPTS= 9000000000000000000"),
    );
    write(d.path(), "dt.AT2", &good.replace("DT= .0100", "DT= 1e-300"));
    write(
        d.path(),
        "cut.AT2",
        &good.trim_end()[..good.trim_end().len() - 3],
    );
    let base = ["predict", "--model", "trilinear+lcfm+viscous", "--params"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["p.json", "--motion", "gm.csv"], "--motion-units"),
        (
            vec!["p.json", "--motion", "bad.csv", "--motion-units", "g"],
            "line 3",
        ),
        (
            vec!["extra.json", "--motion", "gm.csv", "--motion-units", "g"],
            "u4",
        ),
        (
            vec!["p.json", "--motion", "gm.csv", "--motion-units", "furlongs"],
            "--motion-units",
        ),
        (
            vec!["p.json", "--synthetic", "--capacity", "-1"],
            "--capacity",
        ),
        (vec!["p.json", "--motion", "missing.AT2"], "missing.AT2"),
        // Issue 37: each of these aborted, wrapped or answered wrongly.
        (
            vec!["p.json", "--motion", "npts.AT2"],
            "more than the 2000000",
        ),
        (vec!["p.json", "--motion", "dt.AT2"], "time step 1e-300 s"),
        (vec!["p.json", "--motion", "cut.AT2"], "cut short"),
        (vec!["p.json", "--synthetic", "--tail", "1e300"], "tail"),
        (
            vec!["p.json", "--synthetic", "--scale", "1e10"],
            "scale factor",
        ),
        (
            vec!["twice.json", "--synthetic"],
            "duplicate key `u0` at line 1 column 19",
        ),
        (
            vec!["zero.json", "--synthetic"],
            "`u0` = 0: must be nonzero",
        ),
        // A stiffness in the wrong unit: the step count per sample would
        // saturate a cast and the run never end.
        (
            vec!["stiff.json", "--synthetic"],
            "needs more than 100,000 steps per motion sample",
        ),
    ];
    for (rest, needle) in cases {
        let args: Vec<&str> = base.iter().copied().chain(rest.iter().copied()).collect();
        let o = hbis(d.path(), &args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"));
    }
    let o = hbis(d.path(), &["predict", "--fit", "nowhere", "--synthetic"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nowhere"), "{}", stderr(&o));
    // An output folder that holds the fit is refused, the fit untouched.
    let fit_json = r#"{"model": "trilinear+lcfm+viscous", "seed": 1}"#;
    finished_fit(&d.path().join("fit"), fit_json, &[CHAIN]);
    let o = hbis(
        d.path(),
        &["predict", "--fit", "fit", "--synthetic", "--out", "."],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("fit.json"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.path().join("fit/fit.json")).unwrap(),
        fit_json
    );
    // The same fit with an output folder beside it: one draw, as read.
    let o = hbis(
        d.path(),
        &[
            "predict",
            "--fit",
            "fit",
            "--synthetic",
            "--out",
            "p",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["draws"], 1);
    assert!(
        stderr(&o).contains("fewer than --draws 1000"),
        "{}",
        stderr(&o)
    );
}

/// A fit folder changed after its run (issue 37): each change is refused
/// with exit code 2, naming the file, and nothing is predicted from it.
#[test]
fn predict_refuses_a_fit_folder_that_is_not_what_its_run_wrote() {
    let d = tempfile::tempdir().unwrap();
    let fit_json = r#"{"model": "trilinear+lcfm+viscous", "seed": 1}"#;
    let second = CHAIN.replace("0.1166", "0.1167");
    type Tamper = fn(&Path);
    let cases: Vec<(&str, Tamper, &str)> = vec![
        // A refit killed between two chain renames: its run removed the
        // manifest when it started.
        (
            "killed refit",
            |f| std::fs::remove_file(f.join("manifest.json")).unwrap(),
            "did not finish",
        ),
        (
            "chain deleted",
            |f| std::fs::remove_file(f.join("chains/chain-2.csv")).unwrap(),
            "chain-2.csv: listed but cannot be read",
        ),
        (
            "chain of another run beside them",
            |f| {
                std::fs::copy(f.join("chains/chain-1.csv"), f.join("chains/chain-3.csv"))
                    .map(|_| ())
                    .unwrap()
            },
            "chain-3.csv: a chain the run's manifest does not list",
        ),
        (
            "digits changed",
            |f| {
                let p = f.join("chains/chain-1.csv");
                let t = std::fs::read_to_string(&p)
                    .unwrap()
                    .replace("0.53979", "0.53978");
                std::fs::write(p, t).unwrap()
            },
            "chain-1.csv: its SHA-256 differs",
        ),
        (
            "chain cut at a line end",
            |f| {
                let p = f.join("chains/chain-2.csv");
                let t = std::fs::read_to_string(&p).unwrap();
                let cut = t.trim_end().rfind('\n').unwrap() + 1;
                std::fs::write(p, &t[..cut]).unwrap()
            },
            "chain-2.csv:",
        ),
        (
            "model edited",
            |f| {
                let p = f.join("fit.json");
                let t = std::fs::read_to_string(&p)
                    .unwrap()
                    .replace("lcfm", "coulomb");
                std::fs::write(p, t).unwrap()
            },
            "fit.json:",
        ),
    ];
    for (k, (what, tamper, needle)) in cases.into_iter().enumerate() {
        let fit = d.path().join(format!("fit-{k}"));
        finished_fit(&fit, fit_json, &[CHAIN, &second]);
        let (name, ok, out) = (format!("fit-{k}"), format!("ok-{k}"), format!("p-{k}"));
        let args =
            |out: &str| ["predict", "--fit", &name, "--synthetic", "--out", out].map(String::from);
        let o = hbis(d.path(), &args(&ok).each_ref().map(String::as_str));
        assert!(o.status.success(), "untouched, {what}: {}", stderr(&o));
        tamper(&fit);
        let o = hbis(d.path(), &args(&out).each_ref().map(String::as_str));
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{what}: {}", stderr(&o));
        assert!(!d.path().join(out).join("predict.json").exists(), "{what}");
    }
}

/// Issue 37: a full stderr (`/dev/full`) panicked in `eprintln!` (exit
/// 101) when predict printed a warning; the line is lost, the run is not.
#[test]
fn a_full_stderr_loses_lines_not_the_run() {
    let d = tempfile::tempdir().unwrap();
    finished_fit(
        &d.path().join("fit"),
        r#"{"model": "trilinear+lcfm+viscous", "seed": 1}"#,
        &[CHAIN],
    );
    // One draw in the fit: "fewer than --draws 1000" goes to stderr.
    let o = crate::bin::hbis_full_stderr(
        d.path(),
        &["predict", "--fit", "fit", "--synthetic", "--out", "p"],
    );
    assert_eq!(o.status.code(), Some(0));
    assert!(d.path().join("p/predict.json").exists());
}

/// Peak displacement of Test 5 with `u0` under `ag`, computed
/// independently: the numerical engine (Dormand-Prince at 1e-12).
fn independent_peak(u0: f64, dt: f64, ag: &[f64], tail: f64) -> f64 {
    let mut p = Params::table_8_1(5).unwrap();
    p.u0 = u0;
    let ex = Excitation::new(dt, ag, tail).unwrap();
    let system = System::new(&ModelSpec::FULL, &p);
    NumericSystem::with_terms(system, &[])
        .forced(&ex, 1e-12, &mut Vec::new())
        .unwrap()
        .peak_displacement
}

/// Issue 38: `--motions N --pga LIST` pairs the draws with N seeded
/// motions, scales them to each level and reports the fragility of the
/// capacity; each pair's peak is checked against an independent
/// integration of the same draw under the same motion, made here from the
/// library's generator and the documented seeds.
#[test]
fn a_fragility_over_a_suite_of_motions_counts_pairs_beyond_the_capacity() {
    let d = tempfile::tempdir().unwrap();
    let u0s = [0.10, 0.11, 0.12, 0.13];
    let mut chain = String::from("lp__,accept_stat__,u0,uy,uF0,rF0,zeta0,f0,f1,f2,u3\n");
    for u0 in u0s {
        chain +=
            &format!("0,0,{u0},0.01167,0.00234,0.00235,0.02256,0.53979,0.41723,0.37477,0.08252\n");
    }
    let fit_json = r#"{"model": "trilinear+lcfm+viscous", "seed": 1}"#;
    finished_fit(&d.path().join("fit"), fit_json, &[&chain]);
    let kt = hbis::data::ground_motion::KanaiTajimi::default();
    let motions: Vec<_> = (0..3)
        .map(|j| {
            kt.generate(hbis::data::ground_motion::suite_seed(9, j))
                .unwrap()
        })
        .collect();
    let g = 9.80665;
    let levels = [0.2 * g, 0.5 * g];
    // Pair k: draw k mod 4, motion k mod 3.
    let peaks: Vec<Vec<f64>> = levels
        .iter()
        .map(|&pga| {
            (0..4)
                .map(|k| {
                    let m = &motions[k % 3];
                    let ag: Vec<f64> = m.ag.iter().map(|a| a * pga / m.pga()).collect();
                    independent_peak(u0s[k], m.dt, &ag, 5.0)
                })
                .collect()
        })
        .collect();
    // A capacity among the first level's peaks, clear of each.
    let mut sorted = peaks[0].clone();
    sorted.sort_by(f64::total_cmp);
    let capacity = 0.5 * (sorted[1] + sorted[2]);
    let cap = capacity.to_string();
    let j = run_json(
        d.path(),
        &[
            "predict",
            "--fit",
            "fit",
            "--motions",
            "3",
            "--seed",
            "9",
            "--pga",
            "0.2g,4.903325",
            "--capacity",
            &cap,
            "--draws",
            "4",
            "--tail",
            "5",
            "--json",
            "--out",
            "pred",
        ],
    );
    assert_eq!(
        (j["draws"].as_u64(), j["pairs"].as_u64()),
        (Some(4), Some(4))
    );
    assert!(j.get("motion").is_none());
    let ms = j["motions"].as_array().unwrap();
    assert_eq!(ms.len(), 3);
    for (m, want) in ms.iter().zip(&motions) {
        assert!((m["pga"].as_f64().unwrap() - levels[0]).abs() < 1e-9);
        assert!(m["source"]
            .as_str()
            .unwrap()
            .ends_with(&want.source[want.source.len() - 8..]));
    }
    let f = j["fragility"].as_array().unwrap();
    assert_eq!(f.len(), 2);
    for ((point, level), peaks) in f.iter().zip(levels).zip(&peaks) {
        assert!((point["pga_g"].as_f64().unwrap() - level / g).abs() < 1e-12);
        for p in peaks {
            assert!(
                (p - capacity).abs() > 1e-5,
                "capacity {capacity} too near a peak {p}"
            );
        }
        let k = peaks.iter().filter(|&&p| p > capacity).count();
        let p = point["p_exceed"].as_f64().unwrap();
        assert_eq!(p, k as f64 / 4.0, "{point}");
        let (lo, hi) = (
            point["ci_low"].as_f64().unwrap(),
            point["ci_high"].as_f64().unwrap(),
        );
        assert!(lo <= p && p <= hi && hi - lo > 0.1, "{point}");
    }
    assert_eq!(f[0]["p_exceed"], j["p_exceed_capacity"]);
    assert_eq!(j["p_exceed_ci"]["high"], f[0]["ci_high"]);
    let csv = std::fs::read_to_string(d.path().join("pred/draws.csv")).unwrap();
    let motion_col: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(motion_col, ["1", "2", "3", "1"]);
    for name in ["fragility.png", "response.png", "peak-displacement.png"] {
        assert!(d.path().join("pred").join(name).exists(), "{name}");
    }

    // A folder of AT2 files, each scaled to the one level.
    std::fs::create_dir(d.path().join("suite")).unwrap();
    write(&d.path().join("suite"), "a.AT2", &at2());
    write(
        &d.path().join("suite"),
        "b.at2",
        &at2().replace("0.2", "0.4"),
    );
    write(&d.path().join("suite"), "notes.txt", "not a motion");
    write(d.path(), "p.json", TEST5);
    let j = run_json(
        d.path(),
        &[
            "predict",
            "--model",
            "trilinear+lcfm+viscous",
            "--params",
            "p.json",
            "--motions",
            "suite",
            "--pga",
            "0.3g",
            "--tail",
            "5",
            "--json",
            "--out",
            "pred-dir",
        ],
    );
    let ms = j["motions"].as_array().unwrap();
    assert_eq!(ms.len(), 2);
    for m in ms {
        assert!((m["pga"].as_f64().unwrap() - 0.3 * g).abs() < 1e-9, "{m}");
    }
    assert!(j.get("fragility").is_none());
    assert_eq!(j["pairs"], 2);
}

#[test]
fn bad_suite_input_exits_2_naming_what_is_wrong() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "p.json", TEST5);
    write(d.path(), "gm.AT2", &at2());
    std::fs::create_dir(d.path().join("empty")).unwrap();
    let base = [
        "predict",
        "--model",
        "trilinear+lcfm+viscous",
        "--params",
        "p.json",
    ];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--motions", "3", "--pga", "0.1g,0.2g"],
            "give --capacity",
        ),
        (vec!["--motions", "3", "--pga", "fast"], "--pga `fast`"),
        (vec!["--motions", "3", "--pga", "-0.2g"], "--pga `-0.2g`"),
        (vec!["--motions", "0"], "--motions 0"),
        (vec!["--motions", "99999999999999999999999"], "1 to 10000"),
        (vec!["--motions", "nowhere"], "--motions nowhere"),
        (vec!["--motions", "empty"], "no .AT2 file"),
        (vec!["--motion", "gm.AT2", "--pga", "0.2g"], "--scale"),
    ];
    for (rest, needle) in cases {
        let args: Vec<&str> = base.iter().copied().chain(rest.iter().copied()).collect();
        let o = hbis(d.path(), &args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"));
    }
}
