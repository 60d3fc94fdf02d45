//! A MAP whose residual is structured gets a second search from new starts,
//! and the better MAP is kept; a MAP with a white residual gets none. The
//! records are two of `examples/map_robustness.rs` (random parameter sets
//! beyond Table 8.1): on record 558 the first search stops in a local
//! basin (a structured residual) and the second reaches the noise floor;
//! on record 505 the first search reaches it. Which records land in a
//! local basin follows the search's path, which a change of the forward
//! model at round-off can move: when one does, these records are picked
//! again from the example's output (`second search kept` and not
//! `MISSED`; record 517 served until the faster threshold search, 502
//! until the likelihood's sum was formed while sampling).

#[allow(dead_code)]
#[path = "../../examples/map_robustness.rs"]
mod map_robustness;

use crate::bin;

use bin::{hbis, stderr};

#[test]
fn a_structured_residual_triggers_a_second_search_that_is_kept_when_higher() {
    let o = map_robustness::fit_one(558);
    assert_eq!(o.second, Some(true), "second search: {:?}", o.second);
    assert!(o.reached(), "e2 / floor {}", o.ratio);
    let o = map_robustness::fit_one(505);
    assert_eq!(o.second, None);
    assert!(o.reached(), "e2 / floor {}", o.ratio);
}

/// `hbis fit` reports the second search in `fit.json` and on standard
/// error, and the kept MAP leaves no `structured-residual` warning.
#[test]
fn fit_json_reports_the_second_search() {
    let (_, _, syn) = map_robustness::record(558);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("rec.csv"), syn.record.to_csv()).unwrap();
    let o = hbis(
        dir.path(),
        &[
            "fit",
            "--data",
            "rec.csv",
            "--model",
            "trilinear+lcfm+viscous",
            "--out",
            "out",
            "--seed",
            "558",
            "--map-only",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("a second search from new starts reached"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/fit.json")).unwrap())
            .unwrap();
    let s = &v["map_second_search"];
    assert_eq!(s["kept_second"], true, "{s}");
    let (first, second) = (
        s["first_log_posterior"].as_f64().unwrap(),
        s["second_log_posterior"].as_f64().unwrap(),
    );
    assert!(second > first, "{s}");
    assert!((v["log_posterior"].as_f64().unwrap() - second).abs() < 1e-6 * second.abs());
    assert!(s["evaluations"].as_u64().unwrap() > 0);
    let codes: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["code"].as_str().unwrap())
        .collect();
    assert!(!codes.contains(&"structured-residual"), "{codes:?}");
}
