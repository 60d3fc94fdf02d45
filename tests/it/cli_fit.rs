//! `hbis fit` through the real binary: the documented keys, determinism
//! across thread counts, and errors that name the row or field.

use crate::bin;

use bin::{hbis, hbis_with, stderr};

use std::path::Path;
use std::process::Command;

use hbis::model::{ModelSpec, Params};
use rand::{rngs::StdRng, SeedableRng};

/// A Test 5 record with 0.4 s of held (noise-only) samples before release.
fn record(dir: &Path) {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let (syn, _, _) = crate::common::noisy_record(&hbis::model::Model::from(spec), &truth, 9);
    let mut text = String::from("t,a\n");
    for i in 0..80 {
        text.push_str(&format!(
            "{},{}\n",
            i as f64 * 0.005,
            0.002 * ((i % 7) as f64 - 3.0)
        ));
    }
    for (t, a) in syn.record.t().iter().zip(syn.record.a()) {
        text.push_str(&format!("{},{a}\n", 0.4 + t));
    }
    std::fs::write(dir.join("rec.csv"), text).unwrap();
}

fn without_wall_time(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v.as_object_mut()
        .unwrap()
        .remove("wall_time_s")
        .expect("wall_time_s is present");
    if let Some(s) = v.get_mut("sampling") {
        let s = s.as_object_mut().unwrap();
        s.remove("wall_time_s")
            .expect("sampling.wall_time_s is present");
        // "fresh" for a whole run, "resumed" for a resumed one.
        s.remove("checkpoint")
            .expect("sampling.checkpoint is present");
    }
    v
}

/// File text without the lines that carry wall times.
fn strip_times(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.contains("wall_time_s") && !l.contains("seconds"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn fit_json_has_the_documented_keys_and_one_seed_gives_one_result() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let args = |out: &'static str| {
        [
            "fit",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+lcfm+viscous",
            "--seed",
            "7",
            "--out",
            out,
            "--json",
            "--max-steps",
            "300",
            "--walkers",
            "20",
            "--released-force",
            "1180",
            "--static-friction",
            "100",
            "--allow-unconverged",
        ]
    };
    let one = hbis_with(d.path(), &args("one"), "1");
    assert!(one.status.success(), "{}", stderr(&one));
    let two = hbis_with(d.path(), &args("two"), "2");
    assert!(two.status.success(), "{}", stderr(&two));
    let a = without_wall_time(&d.path().join("one/fit.json"));
    let b = without_wall_time(&d.path().join("two/fit.json"));
    assert_eq!(a, b, "same seed, 1 vs 2 threads");
    // Bit-identical text, too, apart from the wall time line.
    let strip = |p: &str| strip_times(&d.path().join(p));
    assert_eq!(strip("one/fit.json"), strip("two/fit.json"));
    for e in 1..=2 {
        let name = format!("chains/chain-{e}.csv");
        assert_eq!(strip(&format!("one/{name}")), strip(&format!("two/{name}")));
    }
    for key in [
        "model",
        "seed",
        "e2",
        "map",
        "log_posterior",
        "evaluations",
        "wall_time_s",
        "polish",
        "data",
    ] {
        let v: serde_json::Value = serde_json::from_slice(&one.stdout).unwrap();
        assert!(v.get(key).is_some(), "--json output lacks `{key}`");
    }
    assert_eq!(a["seed"], 7);
    assert_eq!(a["model"], "trilinear+lcfm+viscous");
    assert_eq!(a["data"]["t0_source"], "detected");
    // The release lies between the last held sample (0.395 s) and the first
    // moving one (0.4 s); the fit places it there.
    let (t0, lag) = (
        a["data"]["t0"].as_f64().unwrap(),
        a["data"]["lag"].as_f64().unwrap(),
    );
    assert!(
        (t0 + lag - 0.4).abs() < 1e-9 && (0.0..0.005).contains(&lag),
        "t0 {t0} lag {lag}"
    );
    assert!(a["map"]["f0"].as_f64().unwrap() > 0.5 && a["map"]["f0"].as_f64().unwrap() < 0.58);
    assert!(a["e2"].as_f64().unwrap() < 0.01);
    // fit.csv keeps the record's clock: its first row is the first sample used.
    let fit_csv = std::fs::read_to_string(d.path().join("one/fit.csv")).unwrap();
    let first_t: f64 = fit_csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (first_t - 0.4).abs() < 1e-12,
        "fit.csv starts at t = {first_t}"
    );
    #[cfg(feature = "figures")]
    for fig in ["fit.png", "corner.png", "trace.png"] {
        assert!(d.path().join("one").join(fig).exists(), "{fig}");
    }
    for k in ["mean", "sd", "q05", "q50", "q95"] {
        assert!(a["posterior"]["f0"][k].is_f64(), "posterior.f0.{k}");
    }
    assert_eq!(a["ranking"].as_array().unwrap().len(), 9);
    let design = &a["identifiability"]["design"];
    assert_eq!(design["parameter"], a["weakest"]);
    assert_eq!(design["rows"].as_array().unwrap().len(), 10);
    let knobs: Vec<&str> = design["scaling"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["knob"].as_str().unwrap())
        .collect();
    assert_eq!(knobs, ["duration", "amplitude", "noise", "rate"]);
    assert!(a["identifiability"]["f0"]["sd_ratio"].is_f64());
    assert_eq!(a["sampling"]["ensembles"], 2);
    assert_eq!(a["sampling"]["steps"], 300);
    // The chains are CmdStan CSV with lp__ first and one row per kept draw;
    // with forces given, eq. 8.1 of each draw follows the parameters.
    let chain = std::fs::read_to_string(d.path().join("one/chains/chain-1.csv")).unwrap();
    let header = chain.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "lp__,accept_stat__,u0,uy,uF0,rF0,zeta0,f0,f1,f2,u3,m,k0,k1,k2,kF,c"
    );
    let rows = chain.lines().filter(|l| !l.starts_with('#')).count() - 1;
    let burn = a["sampling"]["burn_in"].as_u64().unwrap() as usize;
    // Walker-major, every `thin`-th step: half the largest tau by default.
    let thin = a["sampling"]["thin"].as_u64().unwrap() as usize;
    let tau_max = a["sampling"]["tau"]
        .as_object()
        .unwrap()
        .values()
        .map(|t| t.as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(thin, ((tau_max / 2.0) as usize).max(1));
    assert_eq!(a["sampling"]["chain_layout"], "walker-major");
    assert_eq!(rows, (300 - burn).div_ceil(thin) * 20);
    assert!(chain.contains(&format!("#     thin = {thin}\n")));
    // The page to hand over: tables, the explanation, three figures.
    let html = std::fs::read_to_string(d.path().join("one/report.html")).unwrap();
    crate::bin::assert_self_contained(&html, 3);
    let expl = hbis::report::html::escape(a["explanation"].as_str().unwrap());
    assert!(html.contains(&expl), "explanation");
    assert!(html.contains("<th>R-hat</th>") && html.contains("<td>u0</td>"));
    assert!(html.contains("Physical quantities (eq. 8.1)"));
    // Each parameter with the unit its component declares; no blank
    // header row or cell of a title.
    assert!(html.contains("<th>parameter</th><th>unit</th><th>MAP</th>"));
    for (name, unit) in [("u0", "m"), ("f0", "Hz"), ("rF0", "-")] {
        assert!(
            html.contains(&format!("<tr><td>{name}</td><td>{unit}</td>")),
            "{name} ({unit})"
        );
    }
    assert!(!html.contains("<th></th>"), "a blank header");
    // The figures are decimated for the page (fit.csv keeps every sample):
    // a 2,081-sample record with 9 parameters stays well under 1 MB.
    assert!(
        html.len() <= 1_000_000,
        "report.html is {} bytes",
        html.len()
    );
    #[cfg(feature = "figures")]
    {
        // The trace's axes carry units: each parameter's, and the step.
        let trace = html.split("<figure>").nth(3).expect("the trace figure");
        for label in ["u0 (m)", "f0 (Hz)", "zeta0 (-)", "step of the sampler"] {
            assert!(
                trace.contains(&format!(">\n{label}\n</text>")),
                "trace: {label}"
            );
        }
    }
    // The checkpoint is gone after a successful run.
    assert!(!d.path().join("one/checkpoint").exists());
    assert!(stderr(&one).contains("release detected just before the sample at t = 0.4 s"));
    assert!(stderr(&one).contains("release placed by the fit at t0 = "));
}

/// A record that starts with a > 0 (released the other way, or the sensor
/// mounted the other way) is fitted mirrored, and reported in its own sign.
#[test]
fn a_record_released_the_other_way_is_fitted_mirrored() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let text = std::fs::read_to_string(d.path().join("rec.csv")).unwrap();
    let mut flipped = String::from("t,a\n");
    for line in text.lines().skip(1) {
        let (t, a) = line.split_once(',').unwrap();
        flipped.push_str(&format!("{t},{}\n", -a.parse::<f64>().unwrap()));
    }
    std::fs::write(d.path().join("flip.csv"), flipped).unwrap();
    let run = |data: &str, out: &str| {
        let o = hbis(
            d.path(),
            &[
                "fit",
                "--data",
                data,
                "--map-only",
                "--t0",
                "0.4",
                "--out",
                out,
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    run("rec.csv", "plain");
    let o = run("flip.csv", "flip");
    assert!(stderr(&o).contains("fitted mirrored"), "{}", stderr(&o));
    let plain = without_wall_time(&d.path().join("plain/fit.json"));
    let flip = without_wall_time(&d.path().join("flip/fit.json"));
    assert_eq!(plain["data"]["polarity"], 1.0);
    assert_eq!(flip["data"]["polarity"], -1.0);
    assert_eq!(plain["map"], flip["map"]);
    assert_eq!(plain["e2"], flip["e2"]);
    // fit.csv: measured and model in the record's sign.
    let row = |dir: &str| -> Vec<f64> {
        let csv = std::fs::read_to_string(d.path().join(dir).join("fit.csv")).unwrap();
        let line = csv.lines().nth(1).unwrap().to_string();
        line.split(',').map(|v| v.parse().unwrap()).collect()
    };
    let (p, f) = (row("plain"), row("flip"));
    assert!(p[1] < 0.0 && p[2] < 0.0, "{p:?}");
    assert_eq!(f[0], p[0]);
    for k in 1..4 {
        assert_eq!(f[k], -p[k]);
    }
}

#[test]
fn bad_records_and_priors_exit_2_naming_row_or_field() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let cases: [(&str, &str, &str, &str); 5] = [
        ("bad.csv", "t,a\n0,1\n0.005,x\n", "", "row 3, column `a`"),
        (
            "bad.csv",
            "t,a\n0,1\n0.005,2\n0.005,3\n",
            "",
            "row 4: time 0.005 s does not increase",
        ),
        (
            "bad.csv",
            "t,a\n0,1\n0.005,inf\n",
            "",
            "row 3, column `a`: value inf is not finite",
        ),
        (
            "rec.csv",
            "",
            r#"{"f0": {"dist": "normal", "mean": 0.5}}"#,
            "prior for `f0`",
        ),
        (
            "rec.csv",
            "",
            r#"{"k9": {"dist": "uniform", "lower": 0, "upper": 1}}"#,
            "prior for `k9`",
        ),
    ];
    for (data, text, prior, expected) in cases {
        if !text.is_empty() {
            std::fs::write(d.path().join(data), text).unwrap();
        }
        let mut args = vec!["fit", "--data", data, "--out", "o"];
        if !prior.is_empty() {
            std::fs::write(d.path().join("prior.json"), prior).unwrap();
            args.extend(["--prior", "prior.json"]);
        }
        let o = hbis_with(d.path(), &args, "1");
        assert_eq!(o.status.code(), Some(2), "{expected}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(expected),
            "wanted `{expected}` in: {}",
            stderr(&o)
        );
        assert_eq!(stderr(&o).lines().count(), 1, "one line: {}", stderr(&o));
    }
    let o = hbis_with(d.path(), &["fit", "--data", "missing.csv"], "1");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.csv"));
    for target in ["1.5", "0", "nan"] {
        let o = hbis_with(
            d.path(),
            &["fit", "--data", "rec.csv", "--design-target", target],
            "1",
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--design-target"), "{}", stderr(&o));
    }
    let o = hbis_with(d.path(), &["fit", "--data", "rec.csv", "--thin", "0"], "1");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--thin 0"), "{}", stderr(&o));
}

/// A fit of `rec.csv` into `out` too short to converge (200 steps of 16
/// walkers after a 3,000-evaluation MAP).
fn short_fit(out: &str) -> Vec<&str> {
    vec![
        "fit",
        "--data",
        "rec.csv",
        "--model",
        "bilinear+coulomb+viscous",
        "--seed",
        "5",
        "--out",
        out,
        "--max-evals",
        "3000",
        "--walkers",
        "16",
        "--max-steps",
        "200",
        "--no-design",
    ]
}

/// A fit whose sample did not converge writes everything, says why on one
/// line and exits 3; `--allow-unconverged` makes the same run exit 0.
#[test]
fn an_unconverged_fit_exits_3_after_writing_everything() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let o = hbis_with(d.path(), &short_fit("strict"), "2");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    let last = err.lines().last().unwrap();
    assert!(
        last.starts_with("hbis: the posterior sample did not converge: ")
            && last.ends_with("(exit 3; --allow-unconverged exits 0)"),
        "{err}"
    );
    let fit = |out: &str| {
        let text = std::fs::read_to_string(d.path().join(out).join("fit.json")).unwrap();
        serde_json::from_str::<serde_json::Value>(&text).unwrap()
    };
    let strict = fit("strict");
    assert_eq!(strict["sampling"]["converged"], false);
    let reason = strict["sampling"]["not_converged"].as_str().unwrap();
    assert!(last.contains(reason), "{reason} in {last}");
    assert!(d.path().join("strict/manifest.json").exists());
    let mut allowed = short_fit("allowed");
    allowed.push("--allow-unconverged");
    let o = hbis_with(d.path(), &allowed, "2");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("did not converge"), "{}", stderr(&o));
    assert_eq!(fit("allowed")["sampling"]["converged"], false);
}

/// `--thin 1` writes every kept step, `--keep-checkpoint` leaves the
/// checkpoint, `--no-chains` writes no chain file.
#[test]
fn thin_no_chains_and_keep_checkpoint_do_what_they_say() {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let run = |out: &'static str, extra: &[&'static str]| {
        let mut args = short_fit(out);
        args.push("--allow-unconverged");
        args.extend_from_slice(extra);
        let o = hbis_with(d.path(), &args, "2");
        assert!(o.status.success(), "{}", stderr(&o));
        let text = std::fs::read_to_string(d.path().join(out).join("fit.json")).unwrap();
        serde_json::from_str::<serde_json::Value>(&text).unwrap()
    };
    let all = run("all", &["--thin", "1", "--keep-checkpoint"]);
    let burn = all["sampling"]["burn_in"].as_u64().unwrap() as usize;
    assert_eq!(all["sampling"]["thin"], 1);
    let chain = std::fs::read_to_string(d.path().join("all/chains/chain-1.csv")).unwrap();
    let rows = chain.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, (200 - burn) * 16);
    assert!(d.path().join("all/checkpoint/state.json").exists());
    let none = run("none", &["--no-chains"]);
    assert_eq!(none["sampling"]["chains"], serde_json::json!([]));
    assert!(none["sampling"].get("thin").is_none());
    assert!(!d.path().join("none/chains").exists());
    assert!(!d.path().join("none/checkpoint").exists());
    // The same draws behind both: the summaries do not depend on the files.
    assert_eq!(all["posterior"], none["posterior"]);
}

/// A run killed with SIGKILL at random moments and resumed each time ends
/// with exactly the result of an uninterrupted run with the same seed.
#[cfg(unix)]
#[test]
fn killed_and_resumed_runs_end_as_an_uninterrupted_run() {
    use rand::RngExt;
    use std::time::{Duration, Instant};

    let d = tempfile::tempdir().unwrap();
    record(d.path());
    // A budget-bound run (the autocorrelation target is out of reach) of
    // 4,000 steps in 40 chunks.
    let args = |out: &'static str| {
        [
            "fit",
            "--data",
            "rec.csv",
            "--model",
            "bilinear+coulomb+viscous",
            "--seed",
            "11",
            "--out",
            out,
            "--walkers",
            "16",
            "--max-steps",
            "4000",
            "--tau-multiple",
            "1000",
            "--allow-unconverged",
        ]
    };
    let whole = hbis_with(d.path(), &args("whole"), "2");
    assert!(whole.status.success(), "{}", stderr(&whole));
    let state = d.path().join("resumed/checkpoint/state.json");
    let steps_saved = || -> u64 {
        std::fs::read_to_string(&state).map_or(0, |text| {
            let v: serde_json::Value =
                serde_json::from_str(&text).expect("the state file is never torn");
            v["steps"].as_u64().unwrap()
        })
    };
    let mut rng = StdRng::seed_from_u64(2026);
    let mut saved = vec![0u64];
    for _ in 0..5 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_hbis"))
            .current_dir(d.path())
            .env("RAYON_NUM_THREADS", "2")
            .args(args("resumed"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Let the run get past its MAP search and save a new chunk, then
        // kill it at a random moment within the next chunks.
        let start = Instant::now();
        let before = *saved.last().unwrap();
        while steps_saved() <= before && start.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(2));
        }
        std::thread::sleep(Duration::from_secs_f64(rng.random_range(0.0..0.08)));
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run finished before it was killed"
        );
        child.kill().unwrap(); // SIGKILL on unix
        child.wait().unwrap();
        saved.push(steps_saved());
    }
    eprintln!("checkpoints at the kills: {saved:?}");
    assert!(
        saved.windows(2).all(|w| w[1] > w[0]) && *saved.last().unwrap() < 4000,
        "checkpoints {saved:?}"
    );
    let last = hbis_with(d.path(), &args("resumed"), "2");
    assert!(last.status.success(), "{}", stderr(&last));
    assert_eq!(
        without_wall_time(&d.path().join("whole/fit.json")),
        without_wall_time(&d.path().join("resumed/fit.json"))
    );
    for e in 1..=2 {
        let name = format!("chains/chain-{e}.csv");
        assert_eq!(
            strip_times(&d.path().join("whole").join(&name)),
            strip_times(&d.path().join("resumed").join(&name))
        );
    }
}

/// The averaging sensor from the command line: a record made with it is
/// fitted with `--model ...+averaging`, the model named so in fit.json; the
/// sensor acts: it fits closer than the instantaneous sensor, which
/// misfits the samples that straddle a reversal (at 1.5 % noise a small
/// part of `e2`: 0.00248 against 0.00250 on this record).
#[test]
fn the_averaging_sensor_is_named_in_the_model() {
    let d = tempfile::tempdir().unwrap();
    let registry = hbis::model::Registry::builtin();
    let model = registry.parse("trilinear+lcfm+viscous+averaging").unwrap();
    let truth = model
        .theta_from_params(&Params::table_8_1(5).unwrap(), &[])
        .unwrap();
    let (syn, _, _) = crate::common::noisy_record(&model, &truth, 12);
    let mut text = String::from("t,a\n");
    for (t, a) in syn.record.t().iter().zip(syn.record.a()) {
        text.push_str(&format!("{t},{a}\n"));
    }
    std::fs::write(d.path().join("rec.csv"), text).unwrap();
    let e2 = |m: &str, out: &str| {
        let o = hbis(
            d.path(),
            &[
                "fit",
                "--data",
                "rec.csv",
                "--model",
                m,
                "--map-only",
                "--out",
                out,
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let v = without_wall_time(&d.path().join(out).join("fit.json"));
        assert_eq!(v["model"], m);
        v["e2"].as_f64().unwrap()
    };
    let averaging = e2("trilinear+lcfm+viscous+averaging", "avg");
    let instant = e2("trilinear+lcfm+viscous", "inst");
    assert!(averaging < instant, "{averaging} vs {instant}");
}
