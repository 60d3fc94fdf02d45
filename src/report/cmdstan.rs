//! Chains as CmdStan CSV, one file per independent ensemble, so that
//! `cmdstanpy.from_csv`, ArviZ's `from_cmdstan` and R's `posterior` read
//! them.
//!
//! The sampler is not HMC, so the files say `algorithm = fixed_param`,
//! whose columns are `lp__` (the log-posterior, first) and `accept_stat__`
//! (here 1 when the walker's proposal at that step was accepted, else 0),
//! then the parameters. Burn-in is not written (`save_warmup = 0`);
//! `num_warmup` counts its draws.
//!
//! **Walker-major.** A draw is one walker at one kept step; the rows hold
//! walker 1's draws in step order, then walker 2's, and so on. A reader
//! that takes the file as one chain (ArviZ's `from_cmdstan`) then sees each
//! walker's own autocorrelation, and its ESS agrees with the sampler's;
//! step-major rows (the walkers of one step consecutive) interleave nearly
//! independent walkers and made ArviZ report ESS about the number of draws.
//!
//! **Thinned.** Every `thin`-th step after the burn-in is written (`thin`
//! in the header); by default half the run's largest autocorrelation time
//! ([`auto_thin`]), so that the stored draws lose little information and a
//! default fit writes a few MB.

use std::io::Write;

use crate::inference::PosteriorSample;

/// The default thinning: half the largest integrated autocorrelation time
/// over ensembles and parameters, at least 1.
///
/// ```
/// # use hbis::report::cmdstan::thin_for_tau;
/// assert_eq!(thin_for_tau(31.4), 15);
/// assert_eq!(thin_for_tau(1.2), 1);
/// assert_eq!(thin_for_tau(f64::NAN), 1);
/// ```
pub fn thin_for_tau(tau_max: f64) -> usize {
    if tau_max.is_finite() && tau_max >= 2.0 {
        (tau_max / 2.0).floor() as usize
    } else {
        1
    }
}

/// [`thin_for_tau`] of the run's largest autocorrelation time.
pub fn auto_thin(sample: &PosteriorSample) -> usize {
    let tau_max = sample
        .tau
        .iter()
        .flatten()
        .copied()
        .filter(|t| t.is_finite())
        .fold(0.0, f64::max);
    thin_for_tau(tau_max)
}

/// The steps written: every `thin`-th after the burn-in.
pub fn kept_steps(sample: &PosteriorSample, thin: usize) -> impl Iterator<Item = usize> + Clone {
    (sample.burn..sample.steps()).step_by(thin.max(1))
}

/// Quantities computed from each draw, written after the parameters as
/// CmdStan writes generated quantities: their names, and the function of a
/// draw's parameter vector (NaN where a draw has none).
pub struct Derived<'a> {
    /// Column names.
    pub names: &'a [&'a str],
    /// The values of one draw, one per name.
    pub of: &'a (dyn Fn(&[f64]) -> Vec<f64> + Sync),
}

/// Writes ensemble `e` of `sample` as CmdStan CSV, walker-major, every
/// `thin`-th step, with the `derived` quantities of each draw if given.
pub fn write_chain(
    mut out: impl Write,
    sample: &PosteriorSample,
    e: usize,
    model: &str,
    seed: u64,
    thin: usize,
    derived: Option<&Derived>,
) -> std::io::Result<()> {
    let c = &sample.chains[e];
    let walkers = c.walkers();
    let steps = kept_steps(sample, thin);
    let kept = steps.clone().count() * walkers;
    let name: String = model
        .chars()
        .map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '_' })
        .collect();
    writeln!(out, "# stan_version_major = 2")?;
    writeln!(out, "# stan_version_minor = 36")?;
    writeln!(out, "# stan_version_patch = 0")?;
    writeln!(out, "# model = hbis_{name}")?;
    writeln!(out, "# written by hbis {} (affine-invariant ensemble sampler, moves {}; ensemble {} of {}, {walkers} walkers; walker-major: the draws of walker 1, then walker 2, ...)", env!("CARGO_PKG_VERSION"), sample.moves, e + 1, sample.chains.len())?;
    writeln!(out, "# method = sample (Default)")?;
    writeln!(out, "#   sample")?;
    writeln!(out, "#     num_samples = {kept}")?;
    writeln!(out, "#     num_warmup = {}", (sample.burn * walkers).max(1))?;
    writeln!(out, "#     save_warmup = 0")?;
    writeln!(out, "#     thin = {}", thin.max(1))?;
    writeln!(out, "#     adapt")?;
    writeln!(out, "#       engaged = 0")?;
    writeln!(out, "#     algorithm = fixed_param")?;
    writeln!(out, "#     num_chains = 1 (Default)")?;
    writeln!(out, "# id = {}", e + 1)?;
    writeln!(out, "# random")?;
    writeln!(out, "#   seed = {seed}")?;
    writeln!(out, "# output")?;
    writeln!(out, "#   file = chain-{}.csv", e + 1)?;
    write!(out, "lp__,accept_stat__")?;
    for n in &sample.names {
        write!(out, ",{n}")?;
    }
    for n in derived.map_or(&[][..], |d| d.names) {
        write!(out, ",{n}")?;
    }
    writeln!(out)?;
    for w in 0..walkers {
        for s in steps.clone() {
            let moved = s > 0 && c.get(s, w) != c.get(s - 1, w);
            write!(out, "{},{}", c.log_prob_at(s, w), u8::from(moved))?;
            for v in c.get(s, w) {
                write!(out, ",{v}")?;
            }
            if let Some(d) = derived {
                for v in (d.of)(c.get(s, w)) {
                    write!(out, ",{v}")?;
                }
            }
            writeln!(out)?;
        }
    }
    writeln!(out, "# ")?;
    writeln!(out, "#  Elapsed Time: 0 seconds (Warm-up)")?;
    writeln!(
        out,
        "#                {:.3} seconds (Sampling)",
        sample.wall_time
    )?;
    writeln!(
        out,
        "#                {:.3} seconds (Total)",
        sample.wall_time
    )?;
    writeln!(out, "# ")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inference::ensemble::Chain;
    use crate::inference::CheckpointStatus;

    /// 3 walkers x 10 steps of one parameter whose value encodes
    /// `walker * 100 + step`.
    fn sample(burn: usize) -> PosteriorSample {
        let (walkers, steps) = (3, 10);
        let mut samples = Vec::new();
        let mut lp = Vec::new();
        for s in 0..steps {
            for w in 0..walkers {
                samples.push((w * 100 + s) as f64);
                lp.push(-(s as f64));
            }
        }
        PosteriorSample {
            names: vec!["x".into()],
            chains: vec![Chain::from_parts(walkers, 1, samples, lp, vec![0; walkers])],
            burn,
            tau: vec![vec![4.2]],
            ess: vec![1.0],
            rhat: vec![1.0],
            acceptance: vec![1.0],
            converged: true,
            not_converged: String::new(),
            moves: "stretch:1".into(),
            evaluations: 0,
            wall_time: 0.0,
            checkpoint: CheckpointStatus::None,
        }
    }

    fn rows(text: &str) -> Vec<f64> {
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    }

    #[test]
    fn rows_are_walker_major_and_thinned_after_the_burn_in() {
        let s = sample(4);
        let mut out = Vec::new();
        write_chain(&mut out, &s, 0, "m", 1, 3, None).unwrap();
        let text = String::from_utf8(out).unwrap();
        // Steps 4, 7 of walker 0, then of walker 1, then of walker 2.
        assert_eq!(
            rows(&text),
            [4.0, 7.0, 104.0, 107.0, 204.0, 207.0],
            "{text}"
        );
        assert!(text.contains("#     thin = 3\n"));
        assert!(text.contains("#     num_samples = 6\n"));
        assert_eq!(auto_thin(&s), 2);
        let mut all = Vec::new();
        write_chain(&mut all, &s, 0, "m", 1, 1, None).unwrap();
        assert_eq!(rows(&String::from_utf8(all).unwrap()).len(), 18);
    }

    #[test]
    fn derived_quantities_follow_the_parameters_on_every_row() {
        let s = sample(8);
        let twice = |x: &[f64]| vec![2.0 * x[0]];
        let d = Derived {
            names: &["twice_x"],
            of: &twice,
        };
        let mut out = Vec::new();
        write_chain(&mut out, &s, 0, "m", 1, 1, Some(&d)).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("lp__,accept_stat__,x,twice_x\n"), "{text}");
        // The last column is twice the one before it: steps 8, 9 of each walker.
        assert_eq!(rows(&text), [16.0, 18.0, 216.0, 218.0, 416.0, 418.0]);
    }
}
