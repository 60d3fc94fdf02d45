//! Convergence diagnostics across independent ensembles: rank-normalised
//! split R-hat (Vehtari, Gelman, Simpson, Carpenter & Bürkner 2021) and the
//! effective sample size from the integrated autocorrelation time.
//!
//! Walkers of one ensemble are not independent (each moves using the
//! others), so R-hat compares whole ensembles: each ensemble contributes one
//! sequence (its draws in step order), split in halves.
//!
//! # Formula
//! For `M` sequences of length `N`, with means `m_j`, variances `s_j^2`:
//! ```text
//! B = N/(M-1) sum (m_j - m)^2,  W = mean s_j^2,
//! R = sqrt(((N-1)/N W + B/N) / W)
//! ```
//! applied to the rank-normalised draws (bulk) and to the rank-normalised
//! `|x - median|` (tail); R-hat is the larger.
//!
//! ```
//! use hbis::inference::diagnostics::split_rhat;
//!
//! // Two sequences from the same distribution: R-hat near 1.
//! let a: Vec<f64> = (0..1000).map(|i| ((i * 37) % 101) as f64).collect();
//! let b: Vec<f64> = (0..1000).map(|i| ((i * 53) % 101) as f64).collect();
//! assert!((split_rhat(&[a, b]) - 1.0).abs() < 0.01);
//! ```

use statrs::distribution::{ContinuousCDF, Normal};

/// Rank-normalised split R-hat of several sequences of one quantity.
pub fn split_rhat(sequences: &[Vec<f64>]) -> f64 {
    let halves: Vec<&[f64]> = sequences
        .iter()
        .flat_map(|s| {
            let h = s.len() / 2;
            [&s[..h], &s[s.len() - h..]]
        })
        .collect();
    if halves.len() < 2 || halves[0].len() < 2 {
        return f64::NAN;
    }
    let scores = NormalScores::new(halves.iter().map(|h| h.len()).sum());
    let bulk = basic_rhat(&scores.of(&halves));
    let mut all: Vec<f64> = halves.iter().flat_map(|h| h.iter().copied()).collect();
    let med = median(&mut all);
    let folded: Vec<Vec<f64>> = halves
        .iter()
        .map(|h| h.iter().map(|v| (v - med).abs()).collect())
        .collect();
    let folded_refs: Vec<&[f64]> = folded.iter().map(Vec::as_slice).collect();
    let tail = basic_rhat(&scores.of(&folded_refs));
    bulk.max(tail)
}

/// The median, by selection (the order of `x` is lost).
fn median(x: &mut [f64]) -> f64 {
    let n = x.len();
    let (below, mid, _) = x.select_nth_unstable_by(n / 2, f64::total_cmp);
    let mid = *mid;
    if n % 2 == 1 {
        mid
    } else {
        // The largest of the lower half is the other middle value.
        let lower = below.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lower + mid)
    }
}

/// Normal scores `Phi^-1((r - 3/8) / (n + 1/4))` of the ranks `r = 1..n`
/// of `n` pooled draws (Blom's offset): the bulk and the tail R-hat rank
/// the same number of draws, so the table is computed once.
struct NormalScores {
    normal: Normal,
    z: Vec<f64>,
}

impl NormalScores {
    fn new(n: usize) -> Self {
        let normal = Normal::new(0.0, 1.0).expect("standard normal");
        let z = (1..=n).map(|r| blom(&normal, r as f64, n)).collect();
        Self { normal, z }
    }

    /// Normal scores of the pooled ranks of `seqs` (average ranks for
    /// ties), in the shape of `seqs`.
    fn of(&self, seqs: &[&[f64]]) -> Vec<Vec<f64>> {
        // Values with their position in the concatenated sequences: two
        // thirds of the bytes of (value, sequence, index) to sort, and the
        // sort is most of the cost.
        let mut all: Vec<(f64, usize)> = seqs
            .iter()
            .flat_map(|s| s.iter().copied())
            .zip(0..)
            .collect();
        debug_assert_eq!(all.len(), self.z.len());
        all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut flat = vec![0.0; all.len()];
        let mut k = 0;
        while k < all.len() {
            let mut e = k;
            while e + 1 < all.len() && all[e + 1].0 == all[k].0 {
                e += 1;
            }
            let z = if e == k {
                self.z[k]
            } else {
                blom(
                    &self.normal,
                    0.5 * ((k + 1) as f64 + (e + 1) as f64),
                    all.len(),
                )
            };
            for item in &all[k..=e] {
                flat[item.1] = z;
            }
            k = e + 1;
        }
        let mut rest = flat.as_slice();
        seqs.iter()
            .map(|s| {
                let (head, tail) = rest.split_at(s.len());
                rest = tail;
                head.to_vec()
            })
            .collect()
    }
}

/// The normal score of rank `rank` among `n` (Blom's offset).
fn blom(normal: &Normal, rank: f64, n: usize) -> f64 {
    normal.inverse_cdf((rank - 0.375) / (n as f64 + 0.25))
}

fn basic_rhat(seqs: &[Vec<f64>]) -> f64 {
    let m = seqs.len() as f64;
    let n = seqs[0].len() as f64;
    let means: Vec<f64> = seqs.iter().map(|s| s.iter().sum::<f64>() / n).collect();
    let grand = means.iter().sum::<f64>() / m;
    let b = n / (m - 1.0) * means.iter().map(|v| (v - grand).powi(2)).sum::<f64>();
    let w = seqs
        .iter()
        .zip(&means)
        .map(|(s, mu)| s.iter().map(|v| (v - mu).powi(2)).sum::<f64>() / (n - 1.0))
        .sum::<f64>()
        / m;
    if w <= 0.0 {
        return f64::NAN;
    }
    (((n - 1.0) / n * w + b / n) / w).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};

    fn draws(rng: &mut StdRng, n: usize, shift: f64, scale: f64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                shift + scale * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng)
            })
            .collect()
    }

    #[test]
    fn the_median_by_selection_is_the_sorted_middle() {
        for n in 1..40 {
            let mut x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64).collect();
            let mut sorted = x.clone();
            sorted.sort_by(f64::total_cmp);
            let want = if n % 2 == 1 {
                sorted[n / 2]
            } else {
                0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
            };
            assert_eq!(median(&mut x), want, "n = {n}");
        }
    }

    /// Ranks are pooled over the sequences, and tied values share the
    /// average of their ranks.
    #[test]
    fn normal_scores_pool_ranks_and_average_ties() {
        let normal = Normal::new(0.0, 1.0).unwrap();
        let blom = |r: f64| normal.inverse_cdf((r - 0.375) / 5.25);
        let z = NormalScores::new(5).of(&[&[3.0, 1.0], &[1.0, 2.0, 5.0]]);
        assert_eq!(
            z,
            vec![
                vec![blom(4.0), blom(1.5)],
                vec![blom(1.5), blom(3.0), blom(5.0)]
            ]
        );
    }

    #[test]
    fn mixed_sequences_give_one_and_separated_ones_do_not() {
        let mut rng = StdRng::seed_from_u64(1);
        let same: Vec<Vec<f64>> = (0..4).map(|_| draws(&mut rng, 2000, 0.0, 1.0)).collect();
        let r = split_rhat(&same);
        assert!(r < 1.01, "{r}");
        let mut shifted = same.clone();
        shifted[3] = draws(&mut rng, 2000, 1.0, 1.0);
        assert!(split_rhat(&shifted) > 1.1);
        // Same location, different scale: only the tail R-hat sees it.
        let mut wide = same.clone();
        wide[0] = draws(&mut rng, 2000, 0.0, 3.0);
        assert!(split_rhat(&wide) > 1.05);
        // A trend within each sequence: the split halves see it.
        let trend: Vec<Vec<f64>> = (0..4)
            .map(|_| (0..2000).map(|i| i as f64 / 500.0).collect())
            .collect();
        assert!(split_rhat(&trend) > 1.5);
    }

    /// The same numbers as ArviZ 0.23.4's `_rhat_rank` (rank-normalised
    /// split R-hat, bulk and tail, the larger) on the series of
    /// `autocorr`'s ArviZ test: agreeing chains, 11 draws, a slow chain,
    /// negative correlation, and chains a level apart.
    #[test]
    fn split_rhat_matches_arviz() {
        use crate::inference::autocorr::tests::hashed_ar1;
        for ((m, n, phi, off), arviz) in [
            ((4, 500, 0.8, 0.1), 1.014_058_473_087_198_4),
            ((3, 11, 0.5, 0.0), 1.102_982_360_131_939),
            ((8, 300, 0.97, 0.0), 1.270_540_087_012_758_8),
            ((2, 1000, -0.6, 0.0), 0.999_944_503_044_276_6),
            ((6, 400, 0.9, 1.0), 2.653_134_407_516_665),
        ] {
            let r = split_rhat(&hashed_ar1(m, n, phi, off));
            assert!(
                (r - arviz).abs() < 1e-9,
                "{m}x{n} phi {phi}: {r} vs {arviz}"
            );
        }
    }
}
