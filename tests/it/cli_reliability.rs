//! Nothing lost, nothing mixed, nothing silently wrong, through the real
//! binary: the output-folder lock, inputs never written over, stale
//! outputs removed, a manifest that is written last and checks out after a
//! kill at any moment, bounded sizes refused before any work, and no panic
//! when standard output cannot be written.

use crate::bin;

use bin::{hbis, stderr};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hbis::data::synthesize;
use hbis::model::{ModelSpec, Params};
use hbis::report::outdir::{sha256_hex, Manifest, LOCK, MANIFEST};
use rand::{rngs::StdRng, SeedableRng};

/// A 6 s Test 5 record with 1.5 % noise.
fn record(dir: &Path) {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(3);
    let syn = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        0.005,
        1201,
        0.015,
        &mut rng,
    )
    .unwrap();
    std::fs::write(dir.join("rec.csv"), syn.record.to_csv()).unwrap();
}

const QUICK: [&str; 6] = [
    "--model",
    "bilinear+coulomb+viscous",
    "--max-evals",
    "3000",
    "--map-only",
    "--seed",
];

fn fit_args<'a>(out: &'a str, seed: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec!["fit", "--data", "rec.csv", "--out", out];
    v.extend_from_slice(&QUICK);
    v.push(seed);
    v.extend_from_slice(extra);
    v
}

/// `p.json`: Test 5's `bilinear+coulomb+viscous` parameters.
fn params(dir: &Path) {
    std::fs::write(
        dir.join("p.json"),
        r#"{"u0": 0.1166, "uy": 0.01167, "uF0": 0.00219, "zeta0": 0.0436, "f0": 0.51, "f1": 0.433}"#,
    )
    .unwrap();
}

/// The `warnings` codes of a JSON report.
fn warning_codes(report: &Path) -> Vec<String> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["code"].as_str().unwrap().to_string())
        .collect()
}

fn no_panic(o: &std::process::Output) {
    let e = stderr(o);
    assert!(!e.contains("panicked"), "{e}");
    assert_ne!(o.status.code(), Some(101), "{e}");
}

/// Every file the manifest lists has its size and checksum.
fn manifest_checks_out(dir: &Path) -> Manifest {
    let m: Manifest =
        serde_json::from_str(&std::fs::read_to_string(dir.join(MANIFEST)).unwrap()).unwrap();
    assert!(m.complete);
    for f in &m.files {
        let bytes = std::fs::read(dir.join(&f.name)).unwrap();
        assert_eq!(bytes.len() as u64, f.bytes, "{}", f.name);
        assert_eq!(sha256_hex(&bytes), f.sha256, "{}", f.name);
    }
    m
}

#[test]
fn a_second_run_into_a_busy_folder_is_refused_and_a_dead_runs_lock_is_taken_over() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    // A long run: sampling with a budget it will not finish soon.
    let mut first = Command::new(env!("CARGO_BIN_EXE_hbis"))
        .current_dir(d.path())
        .args([
            "fit",
            "--data",
            "rec.csv",
            "--out",
            "out",
            "--model",
            "bilinear+coulomb+viscous",
            "--max-steps",
            "1000000",
            "--tau-multiple",
            "100000",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !d.path().join("out").join(LOCK).exists() && start.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let second = hbis(d.path(), &fit_args("out", "2", &[]));
    no_panic(&second);
    assert_eq!(second.status.code(), Some(2), "{}", stderr(&second));
    let e = stderr(&second);
    assert!(
        e.contains("in use by another hbis run") && e.contains(&first.id().to_string()),
        "{e}"
    );
    first.kill().unwrap();
    first.wait().unwrap();
    // The lock of the killed run is left behind and taken over.
    assert!(d.path().join("out").join(LOCK).exists());
    let third = hbis(d.path(), &fit_args("out", "2", &[]));
    assert!(third.status.success(), "{}", stderr(&third));
    assert!(!d.path().join("out").join(LOCK).exists());
    manifest_checks_out(&d.path().join("out"));
}

#[test]
fn inputs_are_never_written_over() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let out = hbis(d.path(), &fit_args("out", "1", &[]));
    assert!(out.status.success(), "{}", stderr(&out));
    // A record kept in the output folder under an output's name.
    std::fs::copy(d.path().join("rec.csv"), d.path().join("out/fit.csv")).unwrap();
    let before = std::fs::read(d.path().join("out/fit.csv")).unwrap();
    let mut args = fit_args("out", "1", &[]);
    args[2] = "out/fit.csv";
    let o = hbis(d.path(), &args);
    no_panic(&o);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("inside the output folder"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.path().join("out/fit.csv")).unwrap(), before);
    // The record inside the folder named differently (`./`).
    let o = hbis(
        d.path(),
        &["fit", "--data", "rec.csv", "--out", "./", "--map-only"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    params(d.path());
    let p_before = std::fs::read(d.path().join("p.json")).unwrap();
    let sim = |extra: &[&str]| {
        let mut a = vec![
            "simulate",
            "--model",
            "bilinear+coulomb+viscous",
            "--params",
            "p.json",
            "--dt",
            "0.01",
            "--duration",
            "2",
        ];
        a.extend_from_slice(extra);
        hbis(d.path(), &a)
    };
    for extra in [
        &["--out", "x.csv", "--phases", "x.csv"][..],
        &["--out", "p.json"][..],
        &["--phases", "./p.json"][..],
    ] {
        let o = sim(extra);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
    }
    assert_eq!(std::fs::read(d.path().join("p.json")).unwrap(), p_before);
    assert!(!d.path().join("x.csv").exists());
    let o = sim(&["--out", "x.csv", "--phases", "ph.csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_map_only_run_into_an_old_folder_leaves_no_chains_of_the_old_run() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let full = hbis(
        d.path(),
        &[
            "fit",
            "--data",
            "rec.csv",
            "--out",
            "out",
            "--model",
            "bilinear+coulomb+viscous",
            "--max-evals",
            "3000",
            "--walkers",
            "12",
            "--max-steps",
            "200",
            "--allow-unconverged",
        ],
    );
    assert!(full.status.success(), "{}", stderr(&full));
    let m = manifest_checks_out(&d.path().join("out"));
    assert!(m.files.iter().any(|f| f.name == "chains/chain-1.csv"));
    assert!(d.path().join("out/chains/chain-2.csv").exists());
    let again = hbis(d.path(), &fit_args("out", "5", &[]));
    assert!(again.status.success(), "{}", stderr(&again));
    let m = manifest_checks_out(&d.path().join("out"));
    assert_eq!(m.seed, 5);
    assert!(m.files.iter().all(|f| !f.name.starts_with("chains/")));
    for e in 1..=2 {
        assert!(!d.path().join(format!("out/chains/chain-{e}.csv")).exists());
    }
    for stale in ["corner.png", "trace.png"] {
        assert!(!d.path().join("out").join(stale).exists(), "{stale}");
    }
}

/// Killed at random moments while a second configuration runs (and writes)
/// into a complete folder, the folder is never a silent mix: it has either
/// no manifest (visibly incomplete) or one whose every file checks out.
#[cfg(unix)]
#[test]
fn a_kill_at_any_moment_leaves_a_complete_folder_or_a_visibly_incomplete_one() {
    use rand::RngExt;
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let first = hbis(d.path(), &fit_args("out", "1", &[]));
    assert!(first.status.success(), "{}", stderr(&first));
    // How long a whole run takes here, to kill within it.
    let clock = Instant::now();
    let timed = hbis(d.path(), &fit_args("timed", "2", &[]));
    assert!(timed.status.success());
    let whole = clock.elapsed().as_secs_f64();
    let mut rng = StdRng::seed_from_u64(77);
    let (mut incomplete, mut complete) = (0, 0);
    for k in 0..8 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_hbis"))
            .current_dir(d.path())
            .args(fit_args("out", if k % 2 == 0 { "2" } else { "3" }, &[]))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Most kills late in the run, where the outputs are written.
        let at = whole * rng.random_range(0.5..1.1);
        std::thread::sleep(Duration::from_secs_f64(at));
        let _ = child.kill();
        child.wait().unwrap();
        let out = d.path().join("out");
        let names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        if out.join(MANIFEST).exists() {
            let m = manifest_checks_out(&out);
            let report: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.join("fit.json")).unwrap())
                    .unwrap();
            assert_eq!(report["seed"].as_u64(), Some(m.seed), "{names:?}");
            complete += 1;
        } else {
            incomplete += 1;
        }
    }
    eprintln!("kills: {complete} complete folders, {incomplete} visibly incomplete");
    // And the next run into the folder completes it.
    let last = hbis(d.path(), &fit_args("out", "4", &[]));
    assert!(last.status.success(), "{}", stderr(&last));
    assert_eq!(manifest_checks_out(&d.path().join("out")).seed, 4);
    let leftovers: Vec<String> = std::fs::read_dir(d.path().join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect();
    // Temporaries of killed runs may remain (never listed, never read);
    // they carry the killed process's id.
    assert!(
        leftovers.iter().all(|n| n.starts_with('.')),
        "{leftovers:?}"
    );
}

#[test]
fn sizes_are_refused_before_any_work() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    params(d.path());
    for (dt, duration) in [("1e-18", "10"), ("0.001", "1e5")] {
        let o = hbis(
            d.path(),
            &[
                "simulate",
                "--model",
                "bilinear+coulomb+viscous",
                "--params",
                "p.json",
                "--dt",
                dt,
                "--duration",
                duration,
                "--out",
                "x.csv",
            ],
        );
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("limit"), "{}", stderr(&o));
    }
    for extra in [
        &["--walkers", "4"][..],
        &["--walkers", "100000000"][..],
        &["--ensembles", "100000"][..],
    ] {
        let mut args = vec![
            "fit",
            "--data",
            "rec.csv",
            "--out",
            "big",
            "--model",
            "bilinear+coulomb+viscous",
        ];
        args.extend_from_slice(extra);
        let o = hbis(d.path(), &args);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        // Refused before the MAP search, and before the folder is made.
        assert!(!stderr(&o).contains("MAP after"), "{}", stderr(&o));
        assert!(!d.path().join("big").exists());
    }
}

/// An --out that cannot be a folder is refused before any computation.
#[test]
fn an_unusable_output_folder_is_refused_before_the_work() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    std::fs::write(d.path().join("afile"), "x").unwrap();
    for cmd in ["fit", "diagnose", "ladder"] {
        let mut args = vec![cmd, "--data", "rec.csv", "--out", "afile/out"];
        if cmd != "fit" {
            args.extend_from_slice(&["--model", "bilinear+coulomb"]);
        }
        let o = hbis(d.path(), &args);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("afile/out"), "{cmd}: {e}");
        assert!(
            !e.contains("MAP after") && !e.contains("release at"),
            "{cmd}: {e}"
        );
    }
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    let d = tempfile::tempdir().unwrap();
    params(d.path());
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    for args in [
        &[
            "simulate",
            "--model",
            "bilinear+coulomb+viscous",
            "--params",
            "p.json",
            "--dt",
            "0.01",
            "--duration",
            "2",
        ][..],
        &[
            "convert",
            "--model",
            "bilinear+coulomb+viscous",
            "--params",
            "p.json",
            "--released-force",
            "1000",
            "--static-friction",
            "100",
        ][..],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_hbis"))
            .current_dir(d.path())
            .args(args)
            .stdout(full())
            .output()
            .unwrap();
        no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("standard output"), "{}", stderr(&o));
    }
}

/// The warnings about the record and the model's fit, without the one
/// about the search's budget (the tests' fits run on 3,000 evaluations).
fn of_record(codes: &[String]) -> Vec<&str> {
    codes
        .iter()
        .map(String::as_str)
        .filter(|c| *c != "map-at-budget")
        .collect()
}

/// Odd records a user fitted with exit 0 and no word: each now gives a
/// clear exit-2 error or a result whose `warnings` name the problem.
#[test]
fn odd_records_give_an_error_or_a_warning_that_names_the_problem() {
    let d = tempfile::tempdir().unwrap();
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let mut rng = StdRng::seed_from_u64(21);
    let syn = synthesize(
        &hbis::model::Model::from(spec),
        &truth,
        0.005,
        1201,
        0.015,
        &mut rng,
    )
    .unwrap();
    let (t, a) = (syn.record.t().to_vec(), syn.record.a().to_vec());
    // 0.5 s held before the release, with the same noise level.
    let sd = 0.015 * a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let pre: Vec<f64> = (0..100)
        .map(|i| sd * (((i * 7919) % 13) as f64 / 6.0 - 1.0))
        .collect();
    let held_t: Vec<f64> = (0..pre.len() + t.len()).map(|i| i as f64 * 0.005).collect();
    let held_a: Vec<f64> = pre.iter().chain(&a).copied().collect();
    let write = |name: &str, t: &[f64], a: &[f64]| {
        let mut s = String::from("t,a\n");
        for (x, y) in t.iter().zip(a) {
            s.push_str(&format!("{x},{y}\n"));
        }
        std::fs::write(d.path().join(name), s).unwrap();
    };
    let ms: Vec<f64> = t.iter().map(|x| 1e3 * x).collect();
    write("ms.csv", &ms, &a);
    write("mm.csv", &t, &a.iter().map(|v| 1e3 * v).collect::<Vec<_>>());
    write(
        "g.csv",
        &t,
        &a.iter().map(|v| v / 9.80665).collect::<Vec<_>>(),
    );
    let noise: Vec<f64> = (0..t.len())
        .map(|i| 0.1 * (((i * 7919 + 13) % 101) as f64 / 50.0 - 1.0))
        .collect();
    write("noise.csv", &t, &noise);
    write("const.csv", &t, &vec![0.3; t.len()]);
    write(
        "huge.csv",
        &t,
        &a.iter().map(|v| v * 1e306).collect::<Vec<_>>(),
    );
    let mut early = held_a.clone();
    early[30] = -5.0;
    write("glitch-early.csv", &held_t, &early);
    let mut late = held_a.clone();
    late[1000] = 8.0;
    write("glitch-late.csv", &held_t, &late);
    write(
        "dc.csv",
        &held_t,
        &held_a.iter().map(|v| v + 0.3).collect::<Vec<_>>(),
    );
    let mut bom = String::from("\u{feff}t,a\n");
    for (x, y) in t.iter().zip(&a) {
        bom.push_str(&format!("{x},{y}\n"));
    }
    std::fs::write(d.path().join("bom.csv"), bom).unwrap();

    let fit = |name: &str, extra: &[&str]| {
        let out = format!("out-{name}");
        let mut args = vec!["fit", "--data", name, "--out", &out];
        args.extend_from_slice(&QUICK);
        args.push("1");
        args.extend_from_slice(extra);
        let o = hbis(d.path(), &args);
        no_panic(&o);
        let report = d.path().join(&out).join("fit.json");
        let codes: Vec<String> = if o.status.success() {
            warning_codes(&report)
        } else {
            Vec::new()
        };
        (o, codes)
    };
    let warned = |name: &str, code: &str| {
        let (o, codes) = fit(name, &[]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(codes.iter().any(|c| c == code), "{name}: {codes:?}");
        assert!(stderr(&o).contains(&format!("warning [{code}]")), "{name}");
    };
    // A time column in milliseconds is refused (issue 37: its search ran
    // for over 11 minutes), naming the likely cause.
    let (o, _) = fit("ms.csv", &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("milliseconds"), "{}", stderr(&o));
    warned("mm.csv", "acceleration-units");
    warned("g.csv", "acceleration-units");
    warned("noise.csv", "no-release");
    warned("noise.csv", "explains-nothing");
    warned("glitch-late.csv", "outliers");
    warned("dc.csv", "dc-offset");
    for name in ["const.csv", "huge.csv"] {
        let (o, _) = fit(name, &[]);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(name), "{name}: {}", stderr(&o));
    }
    // The unit option fixes the mm/s^2 record: no unit warning, and the
    // fit explains it. (Its residual is structured, and says so: the
    // bilinear Coulomb model lacks the record's third branch and friction
    // slope.)
    let (o, codes) = fit("mm.csv", &["--accel-units", "mm/s2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(of_record(&codes), ["structured-residual"], "{codes:?}");
    // 3,000 evaluations cut the MAP search short, and it says so.
    assert!(codes.iter().any(|c| c == "map-at-budget"), "{codes:?}");
    // A glitch before the release does not move it; dropped, a late one
    // leaves the fit as good as on the clean record.
    let release = |name: &str, extra: &[&str]| -> (f64, f64) {
        let (o, _) = fit(name, extra);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(d.path().join(format!("out-{name}/fit.json"))).unwrap(),
        )
        .unwrap();
        (v["data"]["t0"].as_f64().unwrap(), v["e2"].as_f64().unwrap())
    };
    write("held.csv", &held_t, &held_a);
    let (t0_clean, e2_clean) = release("held.csv", &[]);
    let (t0_early, _) = release("glitch-early.csv", &[]);
    assert!(
        (t0_early - t0_clean).abs() < 0.005,
        "{t0_early} vs {t0_clean}"
    );
    let (t0_late, e2_late) = release("glitch-late.csv", &["--drop-outliers"]);
    assert!(
        (t0_late - t0_clean).abs() < 0.005,
        "{t0_late} vs {t0_clean}"
    );
    assert!(e2_late < 1.5 * e2_clean, "e2 {e2_late} vs clean {e2_clean}");
    // A prior that excludes the truth (f0 0.56 Hz): the fit says so.
    std::fs::write(
        d.path().join("far.json"),
        r#"{"f0": {"dist": "uniform", "lower": 1.5, "upper": 2.0}}"#,
    )
    .unwrap();
    let mut far = vec![
        "fit", "--data", "held.csv", "--out", "out-far", "--prior", "far.json",
    ];
    far.extend_from_slice(&QUICK);
    far.push("1");
    let o = hbis(d.path(), &far);
    assert!(o.status.success(), "{}", stderr(&o));
    let far_codes = warning_codes(&d.path().join("out-far/fit.json"));
    assert!(
        far_codes
            .iter()
            .any(|c| c == "at-bound" || c == "explains-nothing"),
        "{far_codes:?}"
    );
    // diagnose on the noise record: no "no missing effect" verdict.
    let o = hbis(
        d.path(),
        &[
            "diagnose",
            "--data",
            "noise.csv",
            "--model",
            "bilinear+coulomb",
            "--out",
            "diag-noise",
        ],
    );
    no_panic(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.path().join("diag-noise/diagnosis.json")).unwrap(),
    )
    .unwrap();
    let verdict = v["verdict"].as_str().unwrap();
    assert!(!verdict.contains("no missing effect"), "{verdict}");
    assert!(verdict.contains("explains only"), "{verdict}");
    assert!(v["conclusion"]
        .as_str()
        .unwrap()
        .starts_with("No conclusion"));
    let codes = warning_codes(&d.path().join("diag-noise/diagnosis.json"));
    assert!(codes.iter().any(|c| c == "explains-nothing"), "{codes:?}");
    // A byte-order mark is read as nothing: the record raises no warning
    // (the residual's structure is the model's, as above).
    let (o, codes) = fit("bom.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(of_record(&codes), ["structured-residual"], "{codes:?}");
}

/// Eq. 8.1 reads the core's spring: `fit --released-force` of a model whose
/// spring law a component replaces was converted without a word (`convert`
/// refused it); now both refuse it before any work.
#[test]
fn released_forces_are_refused_for_a_replaced_spring_law() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let o = hbis(
        d.path(),
        &[
            "fit",
            "--data",
            "rec.csv",
            "--out",
            "o",
            "--model",
            "bouc-wen+coulomb",
            "--released-force",
            "1000",
            "--static-friction",
            "100",
        ],
    );
    no_panic(&o);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--released-force: model `bouc-wen+coulomb`: eq. 8.1 converts the bilinear and trilinear springs; `bouc-wen` replaces the spring law"),
        "{}",
        stderr(&o)
    );
    assert!(!d.path().join("o").exists());
}
