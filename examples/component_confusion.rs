//! When one record tells a catalog component from the others, and when it
//! cannot: each scenario hides one component in a 10 s, 200 Hz record of a
//! Table 8.1 test and prints how `diagnose` ranks the candidates from a
//! model without it (delta BIC; supported below -10). The numbers quoted
//! in `docs/components.md` come from this example.
//!
//! ```sh
//! cargo run --release --features examples --example component_confusion
//! ```

use hbis::criticism::{caution, diagnose_model};
use hbis::data::synthesize;
use hbis::inference::{MapSettings, Noise};
use hbis::model::{Params, Registry};
use rand::{rngs::StdRng, SeedableRng};

struct Scenario {
    truth: &'static str,
    value: (&'static str, f64),
    start: &'static str,
    test: u32,
    noise: f64,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let registry = Registry::builtin();
    let scenarios = [
        Scenario {
            truth: "trilinear+coulomb+viscous+friction-decay",
            value: ("kappa_F", 3.0),
            start: "trilinear+coulomb+viscous",
            test: 5,
            noise: 0.015,
        },
        Scenario {
            truth: "trilinear+coulomb+viscous+friction-decay",
            value: ("kappa_F", 3.0),
            start: "trilinear+coulomb+viscous",
            test: 5,
            noise: 0.003,
        },
        Scenario {
            truth: "trilinear+lcfm+viscous+friction-decay",
            value: ("kappa_F", 3.0),
            start: "trilinear+lcfm+viscous",
            test: 5,
            noise: 0.015,
        },
        Scenario {
            truth: "trilinear+lcfm+viscous+friction-decay",
            value: ("kappa_F", 3.0),
            start: "trilinear+lcfm+viscous",
            test: 5,
            noise: 0.003,
        },
        Scenario {
            truth: "trilinear+lcfm+viscous+asymmetric-friction",
            value: ("a_F", 0.2),
            start: "trilinear+lcfm+viscous",
            test: 5,
            noise: 0.015,
        },
        Scenario {
            truth: "trilinear+lcfm+viscous+asymmetric-friction",
            value: ("a_F", 0.5),
            start: "trilinear+lcfm+viscous",
            test: 8,
            noise: 0.015,
        },
        Scenario {
            truth: "trilinear+lcfm+viscous+degradation",
            value: ("kappa_k", 0.25),
            start: "trilinear+lcfm+viscous",
            test: 5,
            noise: 0.015,
        },
    ];
    for s in scenarios {
        let truth = registry.parse(s.truth)?;
        let p = truth
            .spec()
            .restrict(&Params::table_8_1(s.test).ok_or("a Table 8.1 test")?)?;
        let theta = truth.theta_from_params(&p, &[s.value])?;
        let mut rng = StdRng::seed_from_u64(3);
        let syn = synthesize(&truth, &theta, 0.005, 2001, s.noise, &mut rng)?;
        let data = syn.record.aligned(None)?;
        let start = registry.parse(s.start)?;
        let (fit, _, ranked) = diagnose_model(
            &registry,
            &start,
            &data,
            Noise::White,
            &MapSettings::default(),
            1,
        )?;
        println!(
            "{} = {} in {} (Test {}, noise {} %), from {}: start e2/floor {:.3}",
            s.value.0,
            s.value.1,
            s.truth,
            s.test,
            100.0 * s.noise,
            s.start,
            fit.e2 / syn.noise_floor
        );
        for c in &ranked {
            println!(
                "    {:20} delta BIC {:>8.1}  e2/floor {:.3}  starts agreeing {}/{}",
                c.effect,
                c.delta_bic,
                c.e2 / syn.noise_floor,
                c.agreeing,
                c.starts
            );
        }
        if let Some(text) = caution(&ranked) {
            println!("    caution: {text}");
        }
    }
    Ok(())
}
