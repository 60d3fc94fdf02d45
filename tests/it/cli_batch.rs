//! `hbis batch`: a study of many records, split into shards and collected,
//! equals the unsplit run; finished items are skipped; bad manifests and
//! missing results are refused with what is wrong.

use crate::bin;

use bin::{hbis, stderr};

use std::path::Path;

use hbis::data::synthesize;
use hbis::model::{Model, Params};
use rand::{rngs::StdRng, SeedableRng};

const RECORDS: usize = 20;

/// Twenty short records (the five Table 8.1 tests, four noise seeds each)
/// and a manifest fitting each with one model and one seed, MAP only.
fn study(dir: &Path) {
    study_of(dir, RECORDS);
}

/// [`study`] with the first `records` records only.
fn study_of(dir: &Path, records: usize) {
    let model = Model::parse("trilinear+lcfm+viscous").unwrap();
    std::fs::create_dir_all(dir.join("records")).unwrap();
    let mut text = String::from(
        "models = [\"bilinear+coulomb+viscous\"]\nseeds = [7]\n\n[fit]\nmap-only = true\nmax-evals = 4000\n",
    );
    for i in 0..records {
        let p = Params::table_8_1([3, 5, 6, 7, 8][i % 5]).unwrap();
        let theta = model.theta_from_params(&p, &[]).unwrap();
        let mut rng = StdRng::seed_from_u64(i as u64);
        let syn = synthesize(&model, &theta, 0.01, 401, 0.015, &mut rng).unwrap();
        let name = format!("rec{i:02}.csv");
        std::fs::write(dir.join("records").join(&name), syn.record.to_csv()).unwrap();
        text.push_str(&format!("\n[[record]]\npath = \"records/{name}\"\n"));
    }
    std::fs::write(dir.join("study.toml"), text).unwrap();
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn shards_collected_equal_the_unsplit_run_and_finished_items_are_skipped() {
    let d = tempfile::tempdir().unwrap();
    study(d.path());
    let run = |args: &[&str]| {
        let mut all = vec!["batch", "--manifest", "study.toml"];
        all.extend_from_slice(args);
        let o = hbis(d.path(), &all);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        stderr(&o)
    };
    run(&["--out", "whole"]);
    let whole = read(&d.path().join("whole/summary.csv"));
    // 20 items x 6 parameters (noise parameters are not in the MAP's table).
    let lines: Vec<&str> = whole.lines().collect();
    assert_eq!(
        lines[0],
        "record,model,seed,parameter,map,mean,sd,q05,q50,q95,ess,rhat,converged,bic,sigma_hat"
    );
    assert_eq!(lines.len(), 1 + RECORDS * 6, "{whole}");
    assert!(
        lines[1].starts_with("rec00,bilinear+coulomb+viscous,7,"),
        "{}",
        lines[1]
    );

    // Collecting before every shard ran names what is missing.
    run(&["--out", "split", "--shard", "1/2"]);
    let o = hbis(
        d.path(),
        &[
            "batch",
            "--manifest",
            "study.toml",
            "--out",
            "split",
            "--collect",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("10 of 20 items have no complete result"),
        "{}",
        stderr(&o)
    );
    assert!(
        stderr(&o).contains("item 2 (record rec01"),
        "{}",
        stderr(&o)
    );

    run(&["--out", "split", "--shard", "2/2"]);
    let one = read(&d.path().join("split/summary-shard-1-of-2.csv"));
    let two = read(&d.path().join("split/summary-shard-2-of-2.csv"));
    assert_eq!(one.lines().count(), 1 + 10 * 6);
    assert_eq!(two.lines().count(), 1 + 10 * 6);
    run(&["--out", "split", "--collect"]);
    assert_eq!(read(&d.path().join("split/summary.csv")), whole);

    // A second run skips every finished item and writes the same summary.
    let err = run(&["--out", "whole"]);
    assert_eq!(err.matches("complete, skipped").count(), RECORDS, "{err}");
    assert_eq!(read(&d.path().join("whole/summary.csv")), whole);

    // A changed record, or changed options, are fitted again.
    let rec = d.path().join("records/rec03.csv");
    let text = read(&rec);
    std::fs::write(&rec, text.replacen("\n0,", "\n0.0,", 1)).unwrap();
    let err = run(&["--out", "whole"]);
    assert_eq!(
        err.matches("complete, skipped").count(),
        RECORDS - 1,
        "{err}"
    );
    assert!(
        err.contains("item 4 (record rec03, model bilinear+coulomb+viscous, seed 7): fitting"),
        "{err}"
    );
}

#[test]
fn bad_manifests_exit_2_naming_what_is_wrong_before_any_fit() {
    let d = tempfile::tempdir().unwrap();
    study(d.path());
    let good = read(&d.path().join("study.toml"));
    for (text, expect) in [
        (
            good.replace("map-only = true", "map-only = \"yes\""),
            "expected true or false",
        ),
        (
            good.replace("max-evals", "max-evls"),
            "`fit.max-evls`: not an option of hbis fit",
        ),
        (good.replace("rec05.csv", "nowhere.csv"), "nowhere.csv"),
        (
            good.replace("bilinear+coulomb+viscous", "bilinear+magic"),
            "magic",
        ),
        (
            good.replace("max-evals = 4000", "max-evals = 0"),
            "item 1 (record rec00, model bilinear+coulomb+viscous, seed 7): `fit.max-evals`: --max-evals",
        ),
        (good.replace("seeds = [7]", "seeds = []"), "`seeds`: empty"),
        // Duplicates would run once and write their rows once per copy.
        (
            good.replace("seeds = [7]", "seeds = [7, 8, 7]"),
            "`seeds[3]`: seed 7 is listed twice (also seeds[1])",
        ),
        (
            good.replace(
                "models = [\"bilinear+coulomb+viscous\"]",
                "models = [\"bilinear+coulomb+viscous\", \"bilinear+viscous+coulomb\"]",
            ),
            "`models[2]`: `bilinear+viscous+coulomb` is the model of models[1]",
        ),
        (
            format!("{good}\n[[record]]\npath = \"records/rec03.csv\"\nname = \"again\"\n"),
            "`record[21]`: record file records/rec03.csv with the same options is listed twice (also record[4])",
        ),
        // A negative number reaches `hbis fit` as the option's value.
        (
            good.replace("max-evals = 4000", "max-evals = 4000\nwalkers = -3"),
            "item 1 (record rec00, model bilinear+coulomb+viscous, seed 7): `fit.walkers`: invalid value '-3' for '--walkers",
        ),
        (
            good.replace("path = \"records/rec02.csv\"", "path = \"records/rec02.csv\"\nwalkers = -3"),
            "item 3 (record rec02, model bilinear+coulomb+viscous, seed 7): `record[3].walkers`: invalid value '-3'",
        ),
        (
            good.replace("max-evals = 4000", "max-evals = 4000\nprior = \"nowhere.json\""),
            "`fit.prior`: cannot read nowhere.json",
        ),
        (
            good.replace("max-evals = 4000", "max-evals = 4000\nwalkers = "),
            "not a TOML study manifest: line 7, column 11, at `fit.walkers`: ",
        ),
    ] {
        std::fs::write(d.path().join("bad.toml"), &text).unwrap();
        let o = hbis(d.path(), &["batch", "--manifest", "bad.toml", "--out", "o"]);
        assert_eq!(o.status.code(), Some(2), "{expect}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{expect}: {}", stderr(&o));
        assert_eq!(stderr(&o).lines().count(), 1, "one line: {}", stderr(&o));
        assert!(
            !d.path().join("o/rec00").exists(),
            "{expect}: fitted before refusing"
        );
    }
    for shard in ["0/2", "3/2", "x"] {
        let o = hbis(
            d.path(),
            &["batch", "--manifest", "study.toml", "--shard", shard],
        );
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains("expected i/n"), "{}", stderr(&o));
    }
}

/// The tail of `batch --manifest sub/study.toml --out o`, run in `dir`.
fn run_sub(dir: &Path) -> String {
    let o = hbis(
        dir,
        &["batch", "--manifest", "sub/study.toml", "--out", "o"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    stderr(&o)
}

#[test]
fn prior_paths_are_the_manifests_and_an_edited_prior_refits_its_items() {
    let d = tempfile::tempdir().unwrap();
    let sub = d.path().join("sub");
    study_of(&sub, 2);
    let prior = |upper: f64| {
        let text = format!(r#"{{"zeta0": {{"dist": "uniform", "lower": 0.0, "upper": {upper}}}}}"#);
        std::fs::write(sub.join("prior.json"), text).unwrap();
    };
    prior(0.2);
    let text = read(&sub.join("study.toml"));
    let text = text.replace(
        "max-evals = 4000",
        "max-evals = 4000\nprior = \"prior.json\"",
    );
    std::fs::write(sub.join("study.toml"), text).unwrap();
    // Run from the manifest's parent: `prior.json` is the one beside it.
    let err = run_sub(d.path());
    assert_eq!(err.matches(": done in").count(), 2, "{err}");
    assert_eq!(run_sub(d.path()).matches("complete, skipped").count(), 2);
    prior(0.15);
    let err = run_sub(d.path());
    assert_eq!(err.matches("complete, skipped").count(), 0, "{err}");
    assert_eq!(err.matches(": done in").count(), 2, "{err}");
}

#[test]
fn a_rerun_removes_the_temporary_files_killed_runs_left_and_nothing_else() {
    let d = tempfile::tempdir().unwrap();
    study_of(d.path(), 2);
    let run = || {
        let o = hbis(
            d.path(),
            &["batch", "--manifest", "study.toml", "--out", "o"],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run();
    let item = d.path().join("o/rec01/bilinear+coulomb+viscous/seed-7");
    std::fs::create_dir_all(item.join("chains")).unwrap();
    // Process ids are below 2^22 on Linux: 4294967000 is no process.
    let dead = 4_294_967_000u32;
    let live = std::process::id();
    let orphans = [
        item.join(format!(".fit.{dead}.tmp.json")),
        item.join(format!("chains/.chain-1.{dead}.tmp.csv")),
        item.join(format!(".batch-item.{dead}.tmp.json")),
        d.path().join(format!("o/.summary.{dead}.tmp.csv")),
    ];
    let kept = [
        // Being written by a live process.
        item.join(format!(".fit.{live}.tmp.json")),
        // Another shard's summary, in the folder shards share.
        d.path()
            .join(format!("o/.summary-shard-1-of-2.{dead}.tmp.csv")),
        // Not a name hbis makes.
        item.join("notes.tmp"),
        item.join(format!(".fit.{dead}.tmp.json.bak")),
    ];
    for p in orphans.iter().chain(&kept) {
        std::fs::write(p, "x").unwrap();
    }
    run();
    for p in &orphans {
        assert!(!p.exists(), "left: {}", p.display());
    }
    for p in &kept {
        assert!(p.exists(), "removed: {}", p.display());
    }
}

/// Issue 37: a full stderr (`/dev/full`) panicked in `eprintln!` (exit
/// 101); the lines are lost, the run is not.
#[test]
fn a_full_stderr_loses_lines_not_the_run() {
    let d = tempfile::tempdir().unwrap();
    study_of(d.path(), 1);
    // Shard 2 of 2 holds no item: it prints its plan and writes its summary.
    let o = crate::bin::hbis_full_stderr(
        d.path(),
        &[
            "batch",
            "--manifest",
            "study.toml",
            "--out",
            "o",
            "--shard",
            "2/2",
        ],
    );
    assert_eq!(o.status.code(), Some(0));
    assert!(d.path().join("o/summary-shard-2-of-2.csv").exists());
}

/// An item whose sample did not converge is done (its outputs are written
/// and its summary rows say `converged` false); the study says so on the
/// item's line and does not fail for it.
#[test]
fn an_unconverged_item_is_done_and_said_so() {
    let d = tempfile::tempdir().unwrap();
    study_of(d.path(), 1);
    let text = read(&d.path().join("study.toml")).replace(
        "map-only = true",
        "walkers = 16\nmax-steps = 200\nno-design = true",
    );
    std::fs::write(d.path().join("study.toml"), text).unwrap();
    let o = hbis(
        d.path(),
        &["batch", "--manifest", "study.toml", "--out", "o"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "item 1 (record rec00, model bilinear+coulomb+viscous, seed 7): the posterior sample did not converge: "
        ),
        "{}",
        stderr(&o)
    );
    let summary = read(&d.path().join("o/summary.csv"));
    let rows: Vec<&str> = summary.lines().skip(1).collect();
    assert!(!rows.is_empty(), "{summary}");
    let header: Vec<&str> = summary.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "converged").unwrap();
    assert!(
        rows.iter().all(|r| r.split(',').nth(col) == Some("false")),
        "{summary}"
    );
}
