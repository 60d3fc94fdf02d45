//! Shared by the integration tests: random parameter sets across every
//! regime of the closed form.
#![allow(dead_code)]

pub mod reference;

use hbis::model::{ModelSpec, Params};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Which regime a random case is built to exercise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    /// Plausible parameters of any model of the family.
    Typical,
    /// Soft second branch and heavy damping: over-damped plastic phases.
    Overdamped,
    /// Damping tuned to critical in the outward plastic phases.
    Critical,
    /// Friction slope cancelling the second branch: `K = 0` exactly.
    ZeroStiffness,
    /// Friction slope beyond it: `K < 0` in outward plastic phases.
    NegativeStiffness,
    /// No damper, no slider: never comes to rest.
    Undamped,
}

pub const REGIMES: [Regime; 6] = [
    Regime::Typical,
    Regime::Overdamped,
    Regime::Critical,
    Regime::ZeroStiffness,
    Regime::NegativeStiffness,
    Regime::Undamped,
];

/// One random simulation to run.
#[derive(Debug, Clone)]
pub struct Case {
    pub regime: Regime,
    pub spec: ModelSpec,
    pub params: Params,
    pub dt: f64,
    pub n: usize,
}

const SPRINGS: [&str; 3] = ["linear", "bilinear", "trilinear"];
const FRICTIONS: [&str; 3] = ["", "+coulomb", "+lcfm"];
const DAMPERS: [&str; 2] = ["", "+viscous"];

fn w2(f: f64) -> f64 {
    (2.0 * std::f64::consts::PI * f).powi(2)
}

/// The `i`-th case of a seeded stream; regimes rotate with `i`.
pub fn random_case(rng: &mut StdRng, i: usize) -> Case {
    let regime = REGIMES[i % REGIMES.len()];
    let f0 = rng.random_range(0.3..1.2);
    let uy = rng.random_range(0.003..0.03);
    let mut p = Params {
        u0: 0.0,
        uy,
        uf0: rng.random_range(0.0..0.005),
        rf0: rng.random_range(-0.03..0.03),
        zeta0: rng.random_range(0.0..0.1),
        f0,
        f1: f0 * rng.random_range(0.4..0.95),
        f2: f0 * rng.random_range(0.3..0.95),
        u3: uy * rng.random_range(1.5..8.0),
    };
    p.u0 = if rng.random_bool(0.15) {
        uy * rng.random_range(0.2..1.0)
    } else {
        p.u3 * rng.random_range(0.3..1.6)
    };
    let mut spec = "trilinear+lcfm+viscous".to_string();
    match regime {
        Regime::Typical => {
            spec = format!(
                "{}{}{}",
                SPRINGS[rng.random_range(0..3)],
                FRICTIONS[rng.random_range(0..3)],
                DAMPERS[rng.random_range(0..2)]
            );
        }
        Regime::Overdamped => {
            p.f2 = f0 * rng.random_range(0.05..0.2);
            p.zeta0 = rng.random_range(0.2..0.6);
            p.rf0 = rng.random_range(0.0..0.01);
        }
        // The next three target phases on a k2 branch, moving inward
        // (K = k2 - k_F, always met in the first branch after release) or
        // outward (K = k2 + k_F, met beyond u3), chosen at random.
        Regime::Critical => {
            p.f2 = f0 * rng.random_range(0.1..0.4);
            p.rf0 = rng.random_range(-0.005..0.005);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let k = w2(p.f2) + sign * p.rf0 * w2(f0);
            p.zeta0 = k.sqrt() / w2(f0).sqrt();
            p.u0 = p.u3 * rng.random_range(0.8..1.6);
        }
        Regime::ZeroStiffness => {
            p.f2 = f0 * rng.random_range(0.1..0.3);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            p.rf0 = sign * w2(p.f2) / w2(f0);
            p.u0 = p.u3 * rng.random_range(0.8..1.6);
        }
        Regime::NegativeStiffness => {
            p.f2 = f0 * rng.random_range(0.1..0.3);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            p.rf0 = sign * w2(p.f2) / w2(f0) * rng.random_range(1.2..3.0);
            p.zeta0 = rng.random_range(0.02..0.15);
            p.u0 = p.u3 * rng.random_range(0.8..1.6);
        }
        Regime::Undamped => spec = SPRINGS[rng.random_range(0..3)].to_string(),
    }
    let spec: ModelSpec = spec.parse().expect("valid spec");
    let params = spec.restrict(&p).expect("valid random parameters");
    let dt = [0.002, 0.005, 0.01][rng.random_range(0..3)];
    let n = (rng.random_range(3.0..15.0) / dt) as usize + 1;
    Case {
        regime,
        spec,
        params,
        dt,
        n,
    }
}

/// A seeded stream of random cases.
pub fn cases(seed: u64, count: usize) -> Vec<Case> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count).map(|i| random_case(&mut rng, i)).collect()
}

/// A 10 s, 200 Hz record of `model` at `theta` with white noise of 1.5 %
/// of its peak (seeded), the record aligned, and its noise floor: the `e2`
/// of the noise-free record on it.
pub fn noisy_record(
    model: &hbis::model::Model,
    theta: &[f64],
    seed: u64,
) -> (hbis::data::Synthetic, hbis::data::Aligned, f64) {
    let mut rng = StdRng::seed_from_u64(seed);
    let syn = hbis::data::synthesize(model, theta, 0.005, 2001, 0.015, &mut rng).unwrap();
    let data = syn.record.aligned(None).unwrap();
    let sse: f64 = data
        .a
        .iter()
        .zip(&syn.clean)
        .map(|(a, c)| (a - c).powi(2))
        .sum();
    let floor = sse / data.energy();
    (syn, data, floor)
}

/// A seed new at every commit, and where it came from: the first eight
/// hexadecimal digits of `git rev-parse HEAD` modulo 10^6 (the convention
/// of the dated calibration runs in docs/criticism.md), or the environment
/// variable `HBIS_CALIBRATION_SEED` to replay a run; `fallback` outside a
/// git checkout.
pub fn commit_seed(fallback: u64) -> (u64, String) {
    if let Ok(s) = std::env::var("HBIS_CALIBRATION_SEED") {
        let seed = s
            .parse()
            .unwrap_or_else(|_| panic!("HBIS_CALIBRATION_SEED `{s}`: expected an integer"));
        return (seed, "HBIS_CALIBRATION_SEED".into());
    }
    let head = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok());
    match head
        .as_deref()
        .and_then(|h| h.get(..8))
        .and_then(|h| u64::from_str_radix(h, 16).ok())
    {
        Some(x) => (
            x % 1_000_000,
            format!("commit {}", head.unwrap_or_default().trim()),
        ),
        None => (fallback, "no git checkout: the fallback".into()),
    }
}
