//! `hbis fit` through the real binary with a damaged checkpoint: a chain
//! file overwritten with garbage is not resumed; the run starts afresh and
//! ends with exactly the result of a clean run.

use crate::bin;

use bin::{hbis, stderr};

use std::path::Path;

use hbis::model::{ModelSpec, Params};

/// A Test 5 record (as in `cli_fit.rs`), released at t = 0.
fn record(dir: &Path) {
    let spec = ModelSpec::FULL;
    let truth = Params::table_8_1(5).unwrap().to_theta(&spec);
    let (syn, _, _) = crate::common::noisy_record(&hbis::model::Model::from(spec), &truth, 9);
    let mut text = String::from("t,a\n");
    for (t, a) in syn.record.t().iter().zip(syn.record.a()) {
        text.push_str(&format!("{t},{a}\n"));
    }
    std::fs::write(dir.join("rec.csv"), text).unwrap();
}

/// fit.json without the wall times and without the checkpoint status
/// (which differs between a clean run and one that discarded a checkpoint).
fn results(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("wall_time_s");
    if let Some(s) = o.get_mut("sampling").and_then(|s| s.as_object_mut()) {
        s.remove("wall_time_s");
        s.remove("checkpoint");
    }
    o.remove("checkpoint");
    v
}

/// The run's checkpoint status in fit.json, wherever the CLI puts it.
fn checkpoint_status(path: &Path) -> Option<serde_json::Value> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v.get("sampling")
        .and_then(|s| s.get("checkpoint"))
        .or_else(|| v.get("checkpoint"))
        .cloned()
}

/// The arguments of a small budget-bound run (the autocorrelation target
/// is out of reach) into `out`.
fn args(out: &str) -> Vec<&str> {
    vec![
        "fit",
        "--data",
        "rec.csv",
        "--t0",
        "0",
        "--model",
        "bilinear+coulomb+viscous",
        "--seed",
        "3",
        "--out",
        out,
        "--max-evals",
        "3000",
        "--walkers",
        "16",
        "--max-steps",
        "300",
        "--tau-multiple",
        "1000",
        // A successful run removes its checkpoint unless told to keep it.
        "--keep-checkpoint",
        // Budget-bound on purpose: not converged, which is not the point.
        "--allow-unconverged",
    ]
}

/// Runs into `out`, damages `out/checkpoint/<file>` with `damage`, reruns
/// with the same arguments (`reruns` times), and checks that the result is
/// finite and equals a clean run's, and that the status names `file`.
fn damaged_checkpoint_is_not_resumed(file: &str, damage: impl Fn(&Path), reruns: usize) {
    let d = tempfile::tempdir().unwrap();
    record(d.path());
    let first = hbis(d.path(), &args("out"));
    assert!(first.status.success(), "{}", stderr(&first));
    damage(&d.path().join("out/checkpoint").join(file));
    for _ in 0..reruns {
        let again = hbis(d.path(), &args("out"));
        assert!(again.status.success(), "{}", stderr(&again));
    }
    let clean = hbis(d.path(), &args("clean"));
    assert!(clean.status.success(), "{}", stderr(&clean));

    let fit = d.path().join("out/fit.json");
    let got = results(&fit);
    let posterior = got["posterior"].as_object().expect("a posterior");
    assert!(!posterior.is_empty());
    assert_eq!(got["sampling"]["steps"], 300);
    for (name, s) in posterior {
        let mean = s["mean"].as_f64();
        assert!(
            mean.is_some_and(f64::is_finite),
            "posterior mean of {name}: {}",
            s["mean"]
        );
    }
    // serde_json's Value compares the numbers exactly.
    assert_eq!(got, results(&d.path().join("clean/fit.json")));
    // After more than one rerun the last one resumes the rewritten
    // checkpoint.
    let status = checkpoint_status(&fit).expect("fit.json has sampling.checkpoint");
    if reruns == 1 {
        assert_eq!(status["status"], "discarded", "{status}");
        let reason = status["reason"].as_str().unwrap_or_default();
        assert!(reason.contains(file), "{status}");
    } else {
        assert_eq!(status["status"], "resumed", "{status}");
    }
}

/// Garbage over the middle of a chain file (0xff.. is a NaN): the
/// checkpoint used to be resumed as it was, giving NaN means.
#[test]
fn a_chain_file_overwritten_with_garbage_is_not_resumed() {
    damaged_checkpoint_is_not_resumed(
        "ensemble-0.bin",
        |p| {
            let mut bytes = std::fs::read(p).unwrap();
            let n = bytes.len();
            assert!(n > 10_000, "{} holds {n} bytes", p.display());
            bytes[n / 3..n / 3 + 4096].fill(0xff);
            std::fs::write(p, bytes).unwrap();
        },
        1,
    );
}

/// A truncated chain file used to be zero-extended in place, after which
/// every rerun failed; now the first rerun starts afresh and the second
/// resumes what it wrote.
#[test]
fn a_truncated_chain_file_is_not_resumed() {
    damaged_checkpoint_is_not_resumed(
        "ensemble-1.bin",
        |p| {
            let n = std::fs::metadata(p).unwrap().len();
            let f = std::fs::OpenOptions::new().write(true).open(p).unwrap();
            f.set_len(n / 2 + 3).unwrap();
        },
        2,
    );
}
