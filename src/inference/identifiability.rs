//! Which parameters the record determines, how well, and why the weakest is
//! weak.
//!
//! Per parameter, from the posterior draws and the prior:
//! - **sd ratio** `sd_post / sd_prior` and **contraction** `1 - ratio^2`:
//!   how much the record narrowed the prior. This is the ranking key (best
//!   determined first): it is scale-free and does not break when a value is
//!   near zero. The posterior c.o.v. `sd / |mean|` (the paper's Table 8.1
//!   measure) is still reported, but not ranked on: a parameter whose mean
//!   is near zero (`rF0`) has an enormous c.o.v. whatever the record says.
//! - **sd in physical units** `sd_post / scale`, with `scale` the
//!   physically meaningful change its component declares (a millimetre of
//!   displacement, 0.01 Hz, a hundredth of a ratio): side by side with the
//!   ratio, to read the sd in terms of the hardware.
//! - **variance inflation** `sd_post / sd_cond`, with `sd_cond =
//!   1/sqrt((Sigma^-1)_kk)` the sd it would have with all other parameters
//!   known (Gaussian approximation of the posterior covariance `Sigma`), and
//!   its **strongest partner**, the parameter it is most correlated with.
//! - where its Fisher information `sum (da_i/dtheta)^2` comes from: the
//!   samples next to reversals, each phase, the first two half-cycles.
//!
//! The explanation of the weakest parameter is computed, and each of its
//! sentences appears only when its number sets the weakest apart from the
//! others (the comparison is printed): a trade-off only when its variance
//! inflation exceeds the others' median; a concentration of information
//! only when its share exceeds the others' median share by 10 points; an
//! unexercised spring branch only when the record has no sample on it.
//! The physical meaning comes from the parameter's declaration
//! ([`crate::model::ParamSpec::meaning`]), owned by its component.
//!
//! # Formula
//! ```text
//! sd_ratio    = sd_post/sd_prior,   contraction = 1 - sd_ratio^2
//! sd_scaled   = sd_post/scale
//! inflation   = sd_post * sqrt((Sigma^-1)_kk)
//! share(G)    = sum_(i in G) s_i^2 / sum_i s_i^2,  s_i = (a_i(theta + h e_k) - a_i(theta - h e_k)) / 2h
//! ```
//!
//! ```
//! use hbis::inference::identifiability::variance_inflation;
//!
//! // Two parameters correlated at 0.9: each sd is 1/sqrt(1 - 0.81) = 2.29
//! // times the sd it would have with the other known.
//! let cov = vec![vec![1.0, 0.9], vec![0.9, 1.0]];
//! let vif = variance_inflation(&cov);
//! assert!((vif[0] - 2.294).abs() < 1e-3);
//! ```

use nalgebra::DMatrix;
use serde::Serialize;

use super::summary::ParamSummary;

/// The identifiability of one parameter.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParamIdentifiability {
    /// Prior-to-posterior contraction, `1 - (sd_post/sd_prior)^2`.
    pub contraction: f64,
    /// Posterior sd over prior sd.
    pub sd_ratio: f64,
    /// Posterior c.o.v., `sd / |mean|` (reported, not ranked on).
    pub cov: f64,
    /// Posterior sd over the physical scale its component declares.
    pub sd_scaled: f64,
    /// Marginal sd over the sd with the other parameters known.
    pub variance_inflation: f64,
    /// The sd it would have with the other parameters known.
    pub sd_conditional: f64,
    /// The parameter it is most correlated with.
    pub partner: String,
    /// That correlation.
    pub partner_correlation: f64,
    /// RMS change of the model acceleration for a one-sd change (m/s^2).
    pub effect_rms: f64,
    /// Share of its Fisher information from the samples within two steps
    /// of a reversal (NaN without segments).
    pub near_reversal_share: f64,
}

/// What the report needs to know of a parameter besides its posterior:
/// its declaration's physical scale and meaning.
#[derive(Debug, Clone)]
pub struct ParamInfo {
    /// Name.
    pub name: String,
    /// A physically meaningful change, in the parameter's unit.
    pub scale: f64,
    /// Unit.
    pub unit: String,
    /// What it does physically (one line, from its component).
    pub meaning: String,
}

/// Labels of the record's samples, for locating information.
#[derive(Debug, Clone)]
pub struct Segments {
    /// Phase of motion at each sample (e.g. `elastic`, `plastic2`, `rest`).
    pub phase: Vec<String>,
    /// Half-cycle index (reversals passed) at each sample.
    pub half_cycle: Vec<usize>,
    /// Whether the sample lies within two steps of a reversal.
    pub near_reversal: Vec<bool>,
    /// Displacement amplitude of each half-cycle (m), if known.
    pub amplitude: Vec<f64>,
}

/// The report.
#[derive(Debug, Clone, Serialize)]
pub struct Identifiability {
    /// Per parameter, in the model's order.
    pub params: Vec<(String, ParamIdentifiability)>,
    /// Names, best determined first.
    pub ranking: Vec<String>,
    /// The least determined parameter.
    pub weakest: String,
    /// Why it is weak, in numbers and physical terms.
    pub explanation: String,
}

/// `sd_marginal / sd_conditional` for each parameter of a covariance matrix.
pub fn variance_inflation(cov: &[Vec<f64>]) -> Vec<f64> {
    let d = cov.len();
    let m = DMatrix::from_fn(d, d, |i, j| cov[i][j]);
    match m.clone().try_inverse() {
        Some(p) => (0..d).map(|k| (cov[k][k] * p[(k, k)]).sqrt()).collect(),
        None => vec![f64::INFINITY; d],
    }
}

/// Builds the report.
///
/// `info[k]` declares parameter `k` (scale, meaning); `effects[k]` is the
/// change of the model acceleration at each sample for a one-sd change of
/// parameter `k` (central differences at the MAP); `sigma` the noise level;
/// `prior_sd[k]` the prior's sd.
#[allow(clippy::too_many_arguments)]
pub fn report(
    names: &[String],
    info: &[ParamInfo],
    summaries: &[ParamSummary],
    cov: &[Vec<f64>],
    prior_sd: &[f64],
    effects: &[Vec<f64>],
    sigma: f64,
    segments: Option<&Segments>,
) -> Identifiability {
    let d = names.len();
    let vif = variance_inflation(cov);
    let mut params = Vec::with_capacity(d);
    for k in 0..d {
        let s = &summaries[k];
        let (mut partner, mut best) = (String::from("-"), 0.0f64);
        for j in 0..d {
            if j != k {
                let r = cov[k][j] / (cov[k][k] * cov[j][j]).sqrt();
                if r.abs() > best.abs() {
                    best = r;
                    partner = names[j].clone();
                }
            }
        }
        let ratio = s.sd / prior_sd[k];
        let rms =
            (effects[k].iter().map(|v| v * v).sum::<f64>() / effects[k].len().max(1) as f64).sqrt();
        params.push((
            names[k].clone(),
            ParamIdentifiability {
                contraction: 1.0 - ratio * ratio,
                sd_ratio: ratio,
                cov: s.sd / s.mean.abs(),
                sd_scaled: s.sd / info[k].scale,
                variance_inflation: vif[k],
                sd_conditional: s.sd / vif[k],
                partner,
                partner_correlation: best,
                effect_rms: rms,
                near_reversal_share: segments
                    .map_or(f64::NAN, |g| share(&effects[k], &g.near_reversal)),
            },
        ));
    }
    let mut order: Vec<usize> = (0..d).collect();
    order.sort_by(|&a, &b| {
        params[a]
            .1
            .sd_ratio
            .total_cmp(&params[b].1.sd_ratio)
            .then(a.cmp(&b))
    });
    let ranking: Vec<String> = order.iter().map(|&k| names[k].clone()).collect();
    let w = *order.last().expect("at least one parameter");
    let next = (d > 1).then(|| order[d - 2]);
    let ctx = Context {
        names,
        info,
        summaries,
        params: &params,
        effects,
        sigma,
        segments,
    };
    let explanation = explain(&ctx, w, next);
    Identifiability {
        params,
        ranking: ranking.clone(),
        weakest: names[w].clone(),
        explanation,
    }
}

/// Share of a parameter's Fisher information from the samples flagged.
fn share(effect: &[f64], flags: &[bool]) -> f64 {
    let total: f64 = effect.iter().map(|v| v * v).sum();
    if total <= 0.0 || flags.len() != effect.len() {
        return f64::NAN;
    }
    let part: f64 = effect
        .iter()
        .zip(flags)
        .filter(|(_, f)| **f)
        .map(|(v, _)| v * v)
        .sum();
    part / total
}

/// Fraction of the samples flagged.
fn fraction(flags: &[bool]) -> f64 {
    flags.iter().filter(|f| **f).count() as f64 / flags.len().max(1) as f64
}

/// A share that sets the weakest apart: 10 points above the others' median.
fn stands_out(own: f64, median: f64) -> bool {
    own.is_finite() && median.is_finite() && own > median + 0.10
}

/// Median of the finite values (NaN if none).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

struct Context<'a> {
    names: &'a [String],
    info: &'a [ParamInfo],
    summaries: &'a [ParamSummary],
    params: &'a [(String, ParamIdentifiability)],
    effects: &'a [Vec<f64>],
    sigma: f64,
    segments: Option<&'a Segments>,
}

impl Context<'_> {
    /// The median of `f` over every parameter but `w`.
    fn others(&self, w: usize, f: impl Fn(usize) -> f64) -> f64 {
        median((0..self.names.len()).filter(|&k| k != w).map(f).collect())
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
}

fn explain(c: &Context, w: usize, next: Option<usize>) -> String {
    let mut text = headline(c, w, next);
    for part in [
        on_its_own(c, w),
        trade_off(c, w),
        response(c, w),
        near_reversals(c, w),
        by_phase(c, w),
        first_half_cycles(c, w),
        unexercised_branch(c, w),
    ]
    .into_iter()
    .flatten()
    {
        text.push(' ');
        text.push_str(&part);
    }
    let meaning = &c.info[w].meaning;
    if !meaning.is_empty() {
        text.push_str(&format!(" Physically, {}: {meaning}.", c.names[w]));
    }
    text
}

fn headline(c: &Context, w: usize, next: Option<usize>) -> String {
    let (name, s, p) = (&c.names[w], &c.summaries[w], &c.params[w].1);
    let unit = match c.info[w].unit.as_str() {
        "-" | "" => String::new(),
        u => format!(" {u}"),
    };
    let mut t = format!(
        "{name} is the least determined parameter: the record narrowed its prior least, to a posterior sd {:.2e}{unit} that is {:.1} % of the prior sd (contraction {:.3}); 90 % interval [{:.4e}, {:.4e}]{}.",
        s.sd,
        100.0 * p.sd_ratio,
        p.contraction,
        s.q05,
        s.q95,
        if s.q05 < 0.0 && s.q95 > 0.0 {
            ", which includes zero: the record does not fix its sign"
        } else {
            ""
        }
    );
    if let Some(n) = next {
        t.push_str(&format!(
            " The next weakest, {}, keeps {:.1} %; the median parameter {:.2} %.",
            c.names[n],
            100.0 * c.params[n].1.sd_ratio,
            100.0 * c.others(w, |k| c.params[k].1.sd_ratio)
        ));
    }
    t.push_str(&format!(
        " In physical terms its sd is {:.2} times {}{unit}, the change its model declares meaningful.",
        p.sd_scaled, c.info[w].scale
    ));
    t
}

/// Only when, with all the others known, it would still be the least
/// determined: the record carries little information on it at all.
fn on_its_own(c: &Context, w: usize) -> Option<String> {
    let cond = |k: usize| c.params[k].1.sd_conditional / c.summaries[k].sd * c.params[k].1.sd_ratio;
    let own = cond(w);
    let worst_other = (0..c.names.len())
        .filter(|&k| k != w)
        .map(cond)
        .fold(f64::NAN, f64::max);
    (own > worst_other).then(|| {
        format!(
            "Even with all the others known it would stay the least determined: its sd would be {:.2} % of the prior sd, against at most {:.2} % (median {:.2} %) for the others, so the record carries little information on it of its own, not only through trade-offs.",
            100.0 * own,
            100.0 * worst_other,
            100.0 * c.others(w, cond)
        )
    })
}

/// Only when the weakest's variance inflation exceeds the others' median.
fn trade_off(c: &Context, w: usize) -> Option<String> {
    let p = &c.params[w].1;
    let med = c.others(w, |k| c.params[k].1.variance_inflation);
    (p.partner != "-" && p.variance_inflation > med).then(|| {
        format!(
            "It trades off with {} (correlation {:+.2}): with the others known its sd would be {:.2e}, {:.1} times smaller (median over the other parameters: {:.1} times).",
            p.partner, p.partner_correlation, p.sd_conditional, p.variance_inflation, med
        )
    })
}

/// Only when a one-sd change of the weakest moves the acceleration less
/// than half as much as the median parameter's.
fn response(c: &Context, w: usize) -> Option<String> {
    let p = &c.params[w].1;
    let med = c.others(w, |k| c.params[k].1.effect_rms);
    (p.effect_rms < 0.5 * med).then(|| {
        format!(
            "The record barely responds to it: a one-sd change moves the acceleration by {:.2e} m/s^2 RMS ({:.0} % of the noise level {:.2e} m/s^2), against a median of {:.2e} m/s^2 for the others.",
            p.effect_rms,
            100.0 * p.effect_rms / c.sigma,
            c.sigma,
            med
        )
    })
}

/// Only when its information is concentrated next to reversals more than
/// the others' (10 points above their median share).
fn near_reversals(c: &Context, w: usize) -> Option<String> {
    let seg = c.segments?;
    let own = c.params[w].1.near_reversal_share;
    let med = c.others(w, |k| c.params[k].1.near_reversal_share);
    let frac = fraction(&seg.near_reversal);
    stands_out(own, med).then(|| {
        format!(
            "{:.0} % of its information comes from the {:.1} % of samples within two steps of a reversal, where friction makes the acceleration jump (median over the other parameters: {:.0} %).",
            100.0 * own,
            100.0 * frac,
            100.0 * med
        )
    })
}

/// The phase that carries most of its information, when its share there
/// exceeds the others' median share by 10 points.
fn by_phase(c: &Context, w: usize) -> Option<String> {
    let seg = c.segments?;
    let mut kinds: Vec<&String> = seg.phase.iter().collect();
    kinds.sort();
    kinds.dedup();
    let flags_of = |kind: &str| -> Vec<bool> { seg.phase.iter().map(|p| p == kind).collect() };
    let (kind, own) = kinds
        .iter()
        .map(|kind| (kind.as_str(), share(&c.effects[w], &flags_of(kind))))
        .filter(|(_, v)| v.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let flags = flags_of(kind);
    let med = c.others(w, |k| share(&c.effects[k], &flags));
    let samples = fraction(&flags);
    stands_out(own, med).then(|| {
        format!(
            "{:.0} % of its information comes from the {kind} phase ({:.0} % of the samples), against a median of {:.0} % for the others.",
            100.0 * own,
            100.0 * samples,
            100.0 * med
        )
    })
}

/// When the first two half-cycles carry more of its information than of
/// the others' (10 points above their median).
fn first_half_cycles(c: &Context, w: usize) -> Option<String> {
    let seg = c.segments?;
    let flags: Vec<bool> = seg.half_cycle.iter().map(|h| *h < 2).collect();
    let own = share(&c.effects[w], &flags);
    let med = c.others(w, |k| share(&c.effects[k], &flags));
    let amp = match (seg.amplitude.get(1), seg.amplitude.get(2)) {
        (Some(a1), Some(a2)) => format!(
            " (amplitudes down to {:.3} m there, {:.3} m by the third)",
            a1.min(seg.amplitude[0]),
            a2
        ),
        _ => String::new(),
    };
    stands_out(own, med).then(|| {
        format!(
            "{:.0} % of its information comes from the first two half-cycles{amp}, against a median of {:.0} % for the others: it shows only at the largest amplitudes.",
            100.0 * own,
            100.0 * med
        )
    })
}

/// When the model has a third spring branch whose start `u3` the record
/// cannot place above or below its largest swing, and the weakest is a
/// parameter of that branch (`u3`, `f2`) or of the one below it (`f1`).
fn unexercised_branch(c: &Context, w: usize) -> Option<String> {
    let seg = c.segments?;
    let u3 = c.index("u3")?;
    if !["u3", "f2", "f1"].contains(&c.names[w].as_str()) {
        return None;
    }
    let swing = seg.amplitude.iter().copied().fold(0.0f64, f64::max);
    let s = &c.summaries[u3];
    if swing < s.q05 {
        Some(format!(
            "The record's largest swing, {swing:.4} m, never passes u3 (posterior 90 % [{:.4}, {:.4}] m): no sample lies on the third branch of the spring, so the record cannot tell where it starts or how stiff it is (f2), and with u3 free to sit anywhere above the swing the second branch (f1) is uncertain too.",
            s.q05, s.q95
        ))
    } else if swing < s.q95 {
        Some(format!(
            "The record's largest swing, {swing:.4} m, lies inside u3's 90 % interval [{:.4}, {:.4}] m: the record cannot tell whether the swing reaches the third branch of the spring at all, so where it starts (u3), how stiff it is (f2) and the second branch below it (f1) trade places.",
            s.q05, s.q95
        ))
    } else if c.names[w] == "f1" {
        // The reading with u3 just above the yield: the second branch is a
        // narrow band of displacement.
        let uy = c.index("uy").map(|k| c.summaries[k].mean)?;
        let on = fraction(
            &seg.phase
                .iter()
                .map(|p| p == "plastic2")
                .collect::<Vec<_>>(),
        );
        if on >= 0.10 {
            return Some(format!(
                "The fit reads the spring with u3 = {:.4} m (90 % [{:.4}, {:.4}] m) below the largest swing {swing:.4} m: the second branch, where f1 acts, is the band from uy = {uy:.4} m to u3 and holds {:.1} % of the samples, and where it ends is itself uncertain.",
                s.mean,
                s.q05,
                s.q95,
                100.0 * on
            ));
        }
        Some(format!(
            "The fit reads the spring with u3 = {:.4} m (90 % [{:.4}, {:.4}] m), between the yield uy = {uy:.4} m and the largest swing {swing:.4} m: the second branch, where f1 acts, spans {:.4} m at the posterior means and holds {:.1} % of the samples at the MAP, so the record hardly sees f1.",
            s.mean,
            s.q05,
            s.q95,
            s.mean - uy,
            100.0 * on
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(mean: f64, sd: f64) -> ParamSummary {
        ParamSummary {
            mean,
            sd,
            cov: sd / mean.abs(),
            q025: mean - 2.0 * sd,
            q05: mean - 1.645 * sd,
            q50: mean,
            q95: mean + 1.645 * sd,
            q975: mean + 2.0 * sd,
            hdi90_low: mean - 1.645 * sd,
            hdi90_high: mean + 1.645 * sd,
        }
    }

    fn info(names: &[String]) -> Vec<ParamInfo> {
        names
            .iter()
            .map(|n| ParamInfo {
                name: n.clone(),
                scale: 0.01,
                unit: "-".into(),
                meaning: format!("meaning of {n}"),
            })
            .collect()
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// Three parameters; `rF0` has a mean near zero (c.o.v. 55) but is
    /// narrowed most, `zeta0` least; `zeta0` trades off with `f0`.
    fn case(near_rev: bool) -> Identifiability {
        let names = names(&["f0", "rF0", "zeta0"]);
        let sums = vec![
            summary(0.54, 0.005),
            summary(0.00002, 0.0011),
            summary(0.05, 0.01),
        ];
        let r = 0.95;
        let cov = vec![
            vec![0.005f64.powi(2), 0.0, r * 0.005 * 0.01],
            vec![0.0, 0.0011f64.powi(2), 0.0],
            vec![r * 0.005 * 0.01, 0.0, 0.01f64.powi(2)],
        ];
        let n = 100;
        // Prior sds: f0 0.5, rF0 0.05, zeta0 0.05: ratios 1 %, 2.2 %, 20 %.
        let prior = [0.5, 0.05, 0.05];
        let effects = vec![
            vec![0.01; n],
            vec![0.01; n],
            (0..n)
                .map(|i| if near_rev && i % 10 == 0 { 0.03 } else { 0.001 })
                .collect(),
        ];
        let seg = Segments {
            phase: (0..n)
                .map(|i| if i < 50 { "plastic2" } else { "elastic" }.to_string())
                .collect(),
            half_cycle: (0..n).map(|i| i / 25).collect(),
            near_reversal: (0..n).map(|i| i % 10 == 0).collect(),
            amplitude: vec![0.1, 0.08, 0.05, 0.02],
        };
        report(
            &names,
            &info(&names),
            &sums,
            &cov,
            &prior,
            &effects,
            0.01,
            Some(&seg),
        )
    }

    #[test]
    fn ranks_by_what_the_record_added_not_by_the_cov() {
        let rep = case(true);
        // By c.o.v. rF0 (5,500 %) would be last; by sd ratio zeta0 is.
        assert!(rep.params[1].1.cov > 50.0);
        assert_eq!(rep.ranking, ["f0", "rF0", "zeta0"]);
        assert_eq!(rep.weakest, "zeta0");
        let e = &rep.explanation;
        assert!(e.starts_with("zeta0 is the least determined"), "{e}");
        assert!(e.contains("20.0 % of the prior sd"), "{e}");
        assert!(e.contains("The next weakest, rF0, keeps 2.2 %"), "{e}");
        assert!(e.contains("meaning of zeta0"), "{e}");
    }

    #[test]
    fn sentences_appear_only_when_their_number_sets_the_weakest_apart() {
        let rep = case(true);
        let e = &rep.explanation;
        // zeta0's inflation 3.2 against a median of 2.2 (f0 3.2, rF0 1).
        assert!(e.contains("trades off with f0 (correlation +0.95)"), "{e}");
        // 10 of 100 samples next to reversals carry 0.009/(0.009+0.00009).
        assert!(
            e.contains("99 % of its information comes from the 10.0 % of samples"),
            "{e}"
        );
        assert!(e.contains("median over the other parameters: 10 %"), "{e}");
        // Its RMS response (0.0095) is not below half the others' (0.01).
        assert!(!e.contains("barely responds"), "{e}");
        // Spread evenly like the others, and weak: no reversal sentence, a
        // response sentence (0.001 against 0.01).
        let flat = case(false);
        let e = &flat.explanation;
        assert!(!e.contains("within two steps of a reversal"), "{e}");
        assert!(e.contains("The record barely responds to it: a one-sd change moves the acceleration by 1.00e-3"), "{e}");
        // The sentence does not depend on the name: rename the weakest.
        let p = &rep.params[2].1;
        assert!(p.near_reversal_share > 0.9);
        assert!((p.variance_inflation - 1.0 / (1.0f64 - 0.9025).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn an_unexercised_third_branch_is_named() {
        let names = names(&["f1", "f2", "u3"]);
        let sums = vec![summary(0.43, 0.001), summary(0.9, 0.5), summary(0.3, 0.1)];
        let cov = vec![
            vec![1e-6, 0.0, 0.0],
            vec![0.0, 0.25, 0.0],
            vec![0.0, 0.0, 0.01],
        ];
        let n = 40;
        let seg = Segments {
            phase: (0..n)
                .map(|i| if i < 20 { "plastic2" } else { "elastic" }.to_string())
                .collect(),
            half_cycle: (0..n).map(|i| i / 10).collect(),
            near_reversal: vec![false; n],
            amplitude: vec![0.08, 0.06, 0.05, 0.04],
        };
        let effects = vec![vec![0.01; n], vec![1e-9; n], vec![1e-9; n]];
        let rep = report(
            &names,
            &info(&names),
            &sums,
            &cov,
            &[0.5, 0.57, 0.14],
            &effects,
            0.01,
            Some(&seg),
        );
        assert_eq!(rep.weakest, "f2");
        let e = &rep.explanation;
        assert!(
            e.contains("largest swing, 0.0800 m, never passes u3"),
            "{e}"
        );
        // A swing inside u3's interval, then beyond it.
        for (swing, says) in [(0.2, Some("lies inside u3's 90 % interval")), (0.5, None)] {
            let mut seg = seg.clone();
            seg.amplitude[0] = swing;
            let rep = report(
                &names,
                &info(&names),
                &sums,
                &cov,
                &[0.5, 0.57, 0.14],
                &effects,
                0.01,
                Some(&seg),
            );
            let e = &rep.explanation;
            assert!(!e.contains("never passes u3"), "{e}");
            match says {
                Some(text) => assert!(e.contains(text), "{e}"),
                None => assert!(!e.contains("u3's 90 %"), "{e}"),
            }
        }
    }
}
