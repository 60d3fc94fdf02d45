//! Several basins of the posterior, from where the MAP search's runs ended.
//!
//! CMA-ES restarts from spread starts (`map.rs`); their ends are samples of
//! the landscape's optima. Two ends lie in separate basins when the
//! log-posterior falls between them: along the straight segment from one to
//! the other it drops more than [`BARRIER`] (10) nats below the lower of the two.
//! A basin more than [`WITHIN`] nats below the MAP holds a negligible share
//! of the posterior (its density is below `e^-10` of the MAP's; only a
//! volume that many times larger could make it matter) and is not kept.
//!
//! Where there are several basins, a Gaussian (Laplace) approximation at
//! the MAP describes one of them; the sampler is started in each
//! ([`crate::inference::sample::SampleSettings::with_basins`]), so that the
//! intervals come from draws over all of them, and the share of the draws
//! nearest each basin is reported ([`shares`]).
//!
//! A straight segment through a curved valley can dip without a second
//! basin; the barrier is then the valley's, and reported as measured.
//!
//! # Formula
//! ```text
//! barrier(a, b) = min(lp(a), lp(b)) - min_{k=1..15} lp(a + k/16 (b - a))
//! separate(a, b) <=> barrier(a, b) > BARRIER
//! ```
//!
//! ```
//! use hbis::inference::basins::barrier;
//! // Two wells at -1 and 1 with a hump between them of height 8 (nats).
//! let lp = |x: &[f64]| Ok::<f64, ()>(-8.0 * (x[0] * x[0] - 1.0).powi(2));
//! let b = barrier(&lp, &[-1.0], &[1.0]).unwrap();
//! assert!((b - 8.0).abs() < 1e-12);
//! // Within one well there is no fall.
//! assert_eq!(barrier(&lp, &[0.9], &[1.1]).unwrap(), 0.0);
//! ```

use serde::Serialize;

use super::map::RunEnd;

/// Fall of the log-posterior (nats) between two ends above which they are
/// separate basins. The likelihood is only piecewise smooth (a reversal
/// crossing a sample instant moves a sample across a friction jump), so it
/// ripples: between two ends 0.001 apart in `uy` of a misfitted
/// `bilinear+coulomb+viscous` fit it fell 2.2 nats (`tests/it/cli_fit.rs`'s
/// record). A fall of 10 nats is no ripple; the basins of
/// `tests/it/basins.rs` and `tests/it/identifiability.rs` are 1,298 and
/// 1,418 nats apart.
pub const BARRIER: f64 = 10.0;

/// Basins more than this many nats below the MAP are not kept.
pub const WITHIN: f64 = 10.0;

/// Interior points at which a segment is evaluated.
const POINTS: usize = 15;

/// One basin of the posterior.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Basin {
    /// Its best point found (the MAP for the first).
    pub theta: Vec<f64>,
    /// The log-posterior there.
    pub log_posterior: f64,
    /// Nats below the MAP.
    pub below_map: f64,
    /// The lowest fall of the log-posterior (nats) on the straight segment
    /// to any basin listed before it (0 for the first).
    pub barrier: f64,
    /// Share of the kept draws nearest to it, once sampled.
    pub share: Option<f64>,
}

/// How far `lp` falls, on the straight segment from `a` to `b`, below the
/// lower of its two ends (0 if it never does). Points outside the prior
/// (`-inf`) count as an infinite fall.
pub fn barrier<E>(lp: &impl Fn(&[f64]) -> Result<f64, E>, a: &[f64], b: &[f64]) -> Result<f64, E> {
    let ends = lp(a)?.min(lp(b)?);
    let mut lowest = f64::INFINITY;
    let mut x = vec![0.0; a.len()];
    for k in 1..=POINTS {
        let t = k as f64 / (POINTS + 1) as f64;
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = a[i] + t * (b[i] - a[i]);
        }
        lowest = lowest.min(lp(&x)?);
    }
    Ok((ends - lowest).max(0.0))
}

/// The basins among the MAP (`map`, its log-posterior `map_lp`) and the
/// runs' `ends`: the MAP first, then each end within [`WITHIN`] nats that
/// is separated by more than [`BARRIER`] from every basin kept before it,
/// best first.
pub fn find<E>(
    lp: &impl Fn(&[f64]) -> Result<f64, E>,
    map: &[f64],
    map_lp: f64,
    ends: &[RunEnd],
) -> Result<Vec<Basin>, E> {
    let mut basins = vec![Basin {
        theta: map.to_vec(),
        log_posterior: map_lp,
        below_map: 0.0,
        barrier: 0.0,
        share: None,
    }];
    let mut near: Vec<&RunEnd> = ends
        .iter()
        .filter(|e| e.log_posterior.is_finite() && e.log_posterior >= map_lp - WITHIN)
        .collect();
    near.sort_by(|a, b| b.log_posterior.total_cmp(&a.log_posterior));
    for e in near {
        let mut lowest = f64::INFINITY;
        for b in &basins {
            lowest = lowest.min(barrier(lp, &e.theta, &b.theta)?);
            if lowest <= BARRIER {
                break;
            }
        }
        if lowest > BARRIER {
            basins.push(Basin {
                theta: e.theta.clone(),
                log_posterior: e.log_posterior,
                below_map: map_lp - e.log_posterior,
                barrier: lowest,
                share: None,
            });
        }
    }
    Ok(basins)
}

/// Each basin's share of `points` (one draw each): a draw belongs to the
/// basin nearest to it in coordinates divided by `scale`, the draws' own
/// marginal standard deviations, so that the coordinates that tell the
/// basins apart (spread over them) weigh as much as those that do not.
pub fn shares(basins: &mut [Basin], points: &[Vec<f64>], scale: &[f64]) {
    let mut counts = vec![0usize; basins.len()];
    for x in points {
        let d = |b: &Basin| -> f64 {
            x.iter()
                .zip(&b.theta)
                .zip(scale)
                .map(|((xi, bi), s)| ((xi - bi) / s).powi(2))
                .sum()
        };
        let nearest = (0..basins.len())
            .min_by(|&i, &j| d(&basins[i]).total_cmp(&d(&basins[j])))
            .unwrap_or(0);
        counts[nearest] += 1;
    }
    let n = points.len().max(1) as f64;
    for (b, c) in basins.iter_mut().zip(counts) {
        b.share = Some(c as f64 / n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn end(x: f64, lp: f64) -> RunEnd {
        RunEnd {
            theta: vec![x],
            log_posterior: lp,
        }
    }

    /// Two wells 30 nats deep with their ends, a duplicate end and an end
    /// far below: two basins, the MAP's first.
    #[test]
    fn two_wells_give_two_basins_and_duplicates_merge() {
        let lp = |x: &[f64]| Ok::<f64, ()>(-30.0 * (x[0] * x[0] - 1.0).powi(2) + 0.5 * x[0]);
        let ends = [
            end(1.0, lp(&[1.0]).unwrap()),
            end(-1.0, lp(&[-1.0]).unwrap()),
            end(0.98, lp(&[0.98]).unwrap()),
        ];
        let b = find(&lp, &[1.0], lp(&[1.0]).unwrap(), &ends).unwrap();
        assert_eq!(b.len(), 2, "{b:?}");
        assert_eq!(b[1].theta, vec![-1.0]);
        assert!((b[1].below_map - 1.0).abs() < 1e-12);
        assert!(b[1].barrier > 25.0, "{}", b[1].barrier);
        // A basin far below the MAP is left out.
        let deep = |x: &[f64]| Ok::<f64, ()>(-30.0 * (x[0] * x[0] - 1.0).powi(2) + 8.0 * x[0]);
        let ends = [end(-1.0, deep(&[-1.0]).unwrap())];
        assert_eq!(
            find(&deep, &[1.0], deep(&[1.0]).unwrap(), &ends)
                .unwrap()
                .len(),
            1
        );
    }

    #[test]
    fn shares_count_the_nearest_basin() {
        let mut b = vec![
            Basin {
                theta: vec![1.0],
                log_posterior: 0.0,
                below_map: 0.0,
                barrier: 0.0,
                share: None,
            },
            Basin {
                theta: vec![-1.0],
                log_posterior: 0.0,
                below_map: 0.0,
                barrier: 9.0,
                share: None,
            },
        ];
        let draws: Vec<Vec<f64>> = [0.9, 1.1, 1.2, -0.8].iter().map(|&x| vec![x]).collect();
        shares(&mut b, &draws, &[0.1]);
        assert_eq!(b[0].share, Some(0.75));
        assert_eq!(b[1].share, Some(0.25));
    }
}
