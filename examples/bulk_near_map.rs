//! How much a MAP on a corner of the likelihood's knife edges loses in
//! the comparison, and what a point next to it keeps.
//!
//! BIC's log-likelihood is what the neighbourhood of a MAP is worth
//! ([`hbis::inference::compare`]: the log-mean-exp over points 1e-6 of
//! each range away), so a MAP that the search drove onto a corner (say two
//! reversals exactly on sample instants, each keeping its sample on the
//! record's side of the jump) counts only what its neighbours are worth.
//! For one calibration record (`criticism::calibration`, hidden effect
//! `HIDDEN[k]`), this fits the start model as `diagnose` does and refits
//! every candidate from its warm start (one local search each, as the
//! ranking's first start), then prints each fit's comparison value at its
//! MAP and the best comparison value among 120 points drawn uniformly
//! within 1e-5 (60) and 1e-4 (60) of each range around it, and on the
//! fixed designs of `inference::laplace::design` at the same two steps
//! (what b29950b's `off_corner` searched), and the BIC changes against the
//! start model each way.
//!
//! ```sh
//! cargo run --release --features examples --example bulk_near_map -- 623499 9 7
//! ```
//! Arguments: the study seed, the record's index in the study, and the
//! hidden effect's index in `HIDDEN` (the record's seed is `seed *
//! 1000003 + index`, as in `criticism::calibration::study`). Not used by
//! the library: a measurement (docs/criticism.md, "The CI failure of
//! 06c5c1c", 2026-12-06).

use hbis::criticism::calibration::{make_record, Kind, Sensor, HIDDEN};
use hbis::criticism::ranking::start_fit;
use hbis::criticism::{fit_model, place_release, priors_for};
use hbis::data::Aligned;
use hbis::inference::laplace::design;
use hbis::inference::{compare, MapSettings, Noise, Posterior};
use hbis::model::{ForwardModel, Model, Registry};
use rand::{rngs::StdRng, RngExt, SeedableRng};

/// The comparison value at `theta`, the best one among the random points
/// near it, and the best one on the fixed designs of
/// [`hbis::inference::laplace::design`] at the same two steps.
fn best_near(
    model: &Model,
    data: &Aligned,
    theta: &[f64],
) -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
    let priors = priors_for(model, Noise::White, data.dt);
    let post = Posterior::new(model.clone(), data.clone(), priors, Noise::White)?;
    let bounds = Posterior::layout_for(model, Noise::White).bounds();
    let at = compare(&post, theta)?.log_likelihood;
    // Points where the model fails are skipped.
    let best_of = |points: Vec<Vec<f64>>| {
        points
            .iter()
            .filter_map(|t| compare(&post, t).ok())
            .fold(at, |m, c| m.max(c.log_likelihood))
    };
    let (lo, hi): (Vec<f64>, Vec<f64>) = bounds.iter().copied().unzip();
    let mut rng = StdRng::seed_from_u64(1);
    let (mut random, mut fixed) = (Vec::new(), Vec::new());
    for scale in [1e-5, 1e-4] {
        for _ in 0..60 {
            random.push(
                theta
                    .iter()
                    .zip(&bounds)
                    .map(|(x, (lo, hi))| {
                        (x + scale * (hi - lo) * rng.random_range(-1.0..1.0)).clamp(*lo, *hi)
                    })
                    .collect(),
            );
        }
        fixed.extend(design(theta, &lo, &hi, scale));
    }
    Ok((at, best_of(random), best_of(fixed)))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed: u64 = args.first().map_or(Ok(623499), |s| s.parse())?;
    let index: u64 = args.get(1).map_or(Ok(9), |s| s.parse())?;
    let hidden: usize = args.get(2).map_or(Ok(7), |s| s.parse())?;
    if hidden >= HIDDEN.len() {
        return Err(format!(
            "hidden effect index {hidden}: expected 0 to {}",
            HIDDEN.len() - 1
        )
        .into());
    }
    let registry = Registry::builtin();
    let s = seed.wrapping_mul(1_000_003).wrapping_add(index);
    let rec = make_record(&registry, Kind::Hidden(hidden), Sensor::Instant, s)?;
    println!("record seed {s}, hidden {}", HIDDEN[hidden].effect);
    let settings = MapSettings::default();
    let data = place_release(&rec.start, rec.data.clone(), &settings, s)?;
    let start = start_fit(&rec.start, &data, Noise::White, &settings, s)?;
    let n = data.a.len() as f64;
    let (s_at, s_near, s_fixed) = best_near(&rec.start, &data, &start.theta)?;
    println!(
        "start {}: comparison log-likelihood {s_at:.2} at the MAP, best near it {s_near:.2} (random), {s_fixed:.2} (design)",
        rec.start.name()
    );
    let theta = start.model_theta(&rec.start).to_vec();
    for c in registry.candidates(&rec.start, &theta) {
        let fit = fit_model(
            &c.model,
            &data,
            Noise::White,
            Some(c.start.clone()),
            &settings,
            s,
        )?;
        let (at, near, fixed) = best_near(&c.model, &data, &fit.theta)?;
        let extra = (fit.theta.len() - start.theta.len()) as f64;
        let bic = |l: f64, l0: f64| extra * n.ln() - 2.0 * (l - l0);
        println!(
            "{:>20}: {at:.2} at the MAP, best near it {near:.2} (random), {fixed:.2} (design); BIC change at the MAPs {:+.1}, best near both {:+.1} (random), {:+.1} (design)",
            c.effect,
            bic(at, s_at),
            bic(near, s_near),
            bic(fixed, s_fixed)
        );
    }
    Ok(())
}
