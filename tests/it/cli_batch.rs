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
    let model = Model::parse("trilinear+lcfm+viscous").unwrap();
    std::fs::create_dir_all(dir.join("records")).unwrap();
    let mut text = String::from(
        "models = [\"bilinear+coulomb+viscous\"]\nseeds = [7]\n\n[fit]\nmap-only = true\nmax-evals = 4000\n",
    );
    for i in 0..RECORDS {
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
            "item 1 (record rec00",
        ),
        (good.replace("seeds = [7]", "seeds = []"), "`seeds`: empty"),
    ] {
        std::fs::write(d.path().join("bad.toml"), &text).unwrap();
        let o = hbis(d.path(), &["batch", "--manifest", "bad.toml", "--out", "o"]);
        assert_eq!(o.status.code(), Some(2), "{expect}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{expect}: {}", stderr(&o));
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
