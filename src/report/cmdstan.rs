//! Chains as CmdStan CSV, one file per independent ensemble, so that
//! `cmdstanpy.from_csv`, ArviZ's `from_cmdstan` and R's `posterior` read
//! them.
//!
//! The sampler is not HMC, so the files say `algorithm = fixed_param`,
//! whose columns are `lp__` (the log-posterior, first) and `accept_stat__`
//! (here 1 when the walker's proposal at that step was accepted, else 0),
//! then the parameters. A draw is one walker at one step, step-major: the
//! walkers of one step are consecutive rows. Burn-in is not written
//! (`save_warmup = 0`); `num_warmup` counts its draws.

use std::io::Write;

use crate::inference::PosteriorSample;

/// Writes ensemble `e` of `sample` as CmdStan CSV.
pub fn write_chain(
    mut out: impl Write,
    sample: &PosteriorSample,
    e: usize,
    model: &str,
    seed: u64,
) -> std::io::Result<()> {
    let c = &sample.chains[e];
    let walkers = c.walkers();
    let kept = (c.steps() - sample.burn) * walkers;
    let name: String = model
        .chars()
        .map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '_' })
        .collect();
    writeln!(out, "# stan_version_major = 2")?;
    writeln!(out, "# stan_version_minor = 36")?;
    writeln!(out, "# stan_version_patch = 0")?;
    writeln!(out, "# model = hbis_{name}")?;
    writeln!(out, "# written by hbis {} (affine-invariant ensemble sampler, stretch move a = 2; ensemble {} of {}, {walkers} walkers)", env!("CARGO_PKG_VERSION"), e + 1, sample.chains.len())?;
    writeln!(out, "# method = sample (Default)")?;
    writeln!(out, "#   sample")?;
    writeln!(out, "#     num_samples = {kept}")?;
    writeln!(out, "#     num_warmup = {}", (sample.burn * walkers).max(1))?;
    writeln!(out, "#     save_warmup = 0")?;
    writeln!(out, "#     thin = 1 (Default)")?;
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
    writeln!(out)?;
    for s in sample.burn..c.steps() {
        for w in 0..walkers {
            let moved = s > 0 && c.get(s, w) != c.get(s - 1, w);
            write!(out, "{},{}", c.log_prob_at(s, w), u8::from(moved))?;
            for v in c.get(s, w) {
                write!(out, ",{v}")?;
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
