//! On synthetic records from every model of the family (known truth, 1.5 %
//! noise), the MAP from the default priors reaches an `e2` at or below the
//! record's noise floor (the `e2` of the truth itself) for at least 19 of 20
//! seeds.

use hbis::data::synthesize;
use hbis::inference::{find_map, MapSettings, Noise, Posterior};
use hbis::model::{ModelSpec, Params};
use rand::{rngs::StdRng, SeedableRng};

const TESTS: [u32; 5] = [3, 5, 6, 7, 8];

fn fit_rate(spec: &str) -> (usize, Vec<String>) {
    let spec: ModelSpec = spec.parse().unwrap();
    let mut ok = 0;
    let mut misses = Vec::new();
    for seed in 0..20u64 {
        let full = Params::table_8_1(TESTS[seed as usize % 5]).unwrap();
        let truth = spec.restrict(&full).unwrap().to_theta(&spec);
        let mut rng = StdRng::seed_from_u64(1000 + seed);
        let syn = synthesize(
            &hbis::model::Model::from(spec),
            &truth,
            0.005,
            2001,
            0.015,
            &mut rng,
        )
        .unwrap();
        let data = syn.record.aligned(None).unwrap();
        let post =
            Posterior::with_default_priors(hbis::model::Model::from(spec), data, Noise::White)
                .unwrap();
        let floor = post.evaluate(&truth).unwrap().e2;
        let map = find_map(&post, &MapSettings::default(), &mut rng).unwrap();
        if map.eval.e2 <= floor * (1.0 + 1e-9) {
            ok += 1;
        } else {
            misses.push(format!(
                "seed {seed}: e2 {:.5} vs floor {:.5} after {} evaluations",
                map.eval.e2, floor, map.cmaes_evaluations
            ));
        }
        eprintln!(
            "{spec} seed {seed}: e2/floor {:.6} evals {} runs {} time {:.3}s",
            map.eval.e2 / floor,
            map.cmaes_evaluations,
            map.runs.len(),
            map.wall_time
        );
    }
    (ok, misses)
}

macro_rules! family_test {
    ($name:ident, $spec:expr) => {
        #[test]
        fn $name() {
            family($spec);
        }
    };
}

fn family(spec: &str) {
    let (ok, misses) = fit_rate(spec);
    assert!(
        ok >= 19,
        "{spec}: {ok}/20 reached the noise floor; {misses:?}"
    );
}

family_test!(linear_none_none, "linear+none+none");
family_test!(linear_none_viscous, "linear+none+viscous");
family_test!(linear_coulomb_none, "linear+coulomb+none");
family_test!(linear_coulomb_viscous, "linear+coulomb+viscous");
family_test!(linear_lcfm_none, "linear+lcfm+none");
family_test!(linear_lcfm_viscous, "linear+lcfm+viscous");
family_test!(bilinear_none_none, "bilinear+none+none");
family_test!(bilinear_none_viscous, "bilinear+none+viscous");
family_test!(bilinear_coulomb_none, "bilinear+coulomb+none");
family_test!(bilinear_coulomb_viscous, "bilinear+coulomb+viscous");
family_test!(bilinear_lcfm_none, "bilinear+lcfm+none");
family_test!(bilinear_lcfm_viscous, "bilinear+lcfm+viscous");
family_test!(trilinear_none_none, "trilinear+none+none");
family_test!(trilinear_none_viscous, "trilinear+none+viscous");
family_test!(trilinear_coulomb_none, "trilinear+coulomb+none");
family_test!(trilinear_coulomb_viscous, "trilinear+coulomb+viscous");
family_test!(trilinear_lcfm_none, "trilinear+lcfm+none");
family_test!(trilinear_lcfm_viscous, "trilinear+lcfm+viscous");
