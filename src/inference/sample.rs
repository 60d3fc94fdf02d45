//! Posterior sampling from the MAP: several independent ensembles of the
//! affine-invariant sampler, run in chunks until every chain is longer than
//! `tau_multiple` autocorrelation times or the budget is spent, with a
//! checkpoint after every chunk.
//!
//! - **Start.** Each ensemble starts in a Gaussian ball around the MAP whose
//!   per-coordinate width is the conditional standard deviation there (the
//!   step along one axis that lowers the log-posterior by 1/2), redrawn
//!   until every walker has positive density and the walkers span all
//!   dimensions.
//! - **Burn-in and convergence.** At checks (every chunk at first, then
//!   every fifth of the run so far) the autocorrelation time `tau` of every
//!   parameter in every ensemble is estimated on the second half of the
//!   chain (the multi-chain estimate of [`effective_time`], each walker a
//!   chain); burn-in is `burn_multiple * tau_max` steps (at most half the
//!   run). `tau` is then estimated again on the kept part, the window the
//!   rule judges, and the run stops once the kept part is `tau_multiple`
//!   (or, with an ESS target, `trust_multiple`) times that long, the ESS
//!   target is reached if there is one, and split R-hat is at most
//!   [`RHAT_MAX`].
//! - **Determinism and resumption.** Ensemble `e`'s random numbers in chunk
//!   `c` come from a generator seeded by `(seed, e, c)` alone. A checkpoint
//!   is written after each chunk (chains appended to one binary file per
//!   ensemble, then a small state file replaced atomically), so a run killed
//!   at any moment resumes from the last complete chunk and ends with
//!   exactly the result of an uninterrupted run.
//! - **Integrity.** The state file holds, per ensemble, the length and the
//!   64-bit FNV-1a checksum of the steps it covers, and a checksum of its
//!   own content (acceptance counts included). A checkpoint is resumed
//!   only if the state parses, has this format version and the run's
//!   fingerprint, and every chain file holds those bytes with finite values;
//!   otherwise it is discarded (the reason in
//!   [`PosteriorSample::checkpoint`]) and the run starts afresh, deleting the
//!   old files first. Files are only ever appended to or replaced by rename:
//!   steps written after the last state (a run killed between the two) are
//!   dropped by copying the verified prefix to a new file.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::autocorr::effective_time;
use super::diagnostics::split_rhat;
use super::ensemble::{Chain, Ensemble, EnsembleSampler, LogDensity, Moves, SamplerError};
use super::summary::ParamSummary;

/// Why posterior sampling failed.
#[derive(Debug, Error)]
pub enum SampleError {
    /// A setting is out of range.
    #[error("sampler setting `{name}`: {reason}")]
    Setting {
        name: &'static str,
        reason: &'static str,
    },
    /// The sampler failed.
    #[error(transparent)]
    Sampler(#[from] SamplerError),
    /// No valid starting ensemble could be drawn around the MAP.
    #[error("could not draw {walkers} walkers with positive density spanning all {dim} dimensions around the MAP")]
    Start { walkers: usize, dim: usize },
    /// The checkpoint could not be read or written.
    #[error("checkpoint {path}")]
    Checkpoint {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// Settings of a posterior run.
#[derive(Debug, Clone)]
pub struct SampleSettings {
    walkers: Option<usize>,
    ensembles: usize,
    chunk: usize,
    tau_multiple: f64,
    burn_multiple: f64,
    max_steps: usize,
    ess: Option<f64>,
    trust_multiple: f64,
    moves: Moves,
    basins: Vec<Vec<f64>>,
}

/// The autocorrelation time is trusted only from a kept chain this many of
/// its own estimates long. The estimate is the multi-chain one of
/// [`effective_time`] (between-walker variance counted, chains split), and
/// with it the claimed Monte Carlo standard errors of runs stopped at ESS
/// 1,000 matched the observed errors of their means, over 100-200
/// independent runs, from this multiple on (`docs/inference.md`,
/// `examples/ess_rule.rs`). emcee's single-walker estimate needs 50
/// (Foreman-Mackey et al. 2013): it ignores the spread between walkers.
pub const TAU_TRUSTED: f64 = 5.0;

/// Largest split R-hat of a converged run.
pub const RHAT_MAX: f64 = 1.01;

/// The default moves (chosen by measurement: `docs/inference.md`).
pub const DEFAULT_MOVES: &str = "gaussian:0.8,stretch:0.2";

/// The default number of independent ensembles (chosen by measurement:
/// `docs/inference.md`). Two give four split halves for R-hat; more
/// ensembles of the same size cost as many more evaluations.
pub const DEFAULT_ENSEMBLES: usize = 2;

impl Default for SampleSettings {
    fn default() -> Self {
        Self {
            walkers: None,
            ensembles: DEFAULT_ENSEMBLES,
            chunk: 100,
            tau_multiple: 50.0,
            burn_multiple: 5.0,
            max_steps: 20_000,
            ess: None,
            trust_multiple: TAU_TRUSTED,
            moves: Moves::parse(DEFAULT_MOVES).expect("valid default moves"),
            basins: Vec::new(),
        }
    }
}

impl SampleSettings {
    /// Walkers per ensemble (even, at least `2 dim`; default
    /// `max(32, 8 dim)` rounded up to even).
    pub fn with_walkers(mut self, n: usize) -> Result<Self, SampleError> {
        if n < 4 || n % 2 != 0 {
            return Err(SampleError::Setting {
                name: "walkers",
                reason: "must be an even number, at least 4",
            });
        }
        self.walkers = Some(n);
        Ok(self)
    }

    /// Independent ensembles (default [`DEFAULT_ENSEMBLES`]; R-hat needs at
    /// least 2).
    pub fn with_ensembles(mut self, n: usize) -> Result<Self, SampleError> {
        if n < 2 {
            return Err(SampleError::Setting {
                name: "ensembles",
                reason: "must be at least 2",
            });
        }
        self.ensembles = n;
        Ok(self)
    }

    /// Steps per chunk (checkpoint interval; default 100).
    pub fn with_chunk(mut self, n: usize) -> Result<Self, SampleError> {
        if n == 0 {
            return Err(SampleError::Setting {
                name: "chunk",
                reason: "must be > 0",
            });
        }
        self.chunk = n;
        Ok(self)
    }

    /// Stop once the kept chain is this many autocorrelation times long
    /// (default 50).
    pub fn with_tau_multiple(mut self, k: f64) -> Result<Self, SampleError> {
        if !(k > 0.0 && k.is_finite()) {
            return Err(SampleError::Setting {
                name: "tau_multiple",
                reason: "must be finite and > 0",
            });
        }
        self.tau_multiple = k;
        Ok(self)
    }

    /// Burn-in in autocorrelation times (default 5).
    pub fn with_burn_multiple(mut self, k: f64) -> Result<Self, SampleError> {
        if !(k >= 0.0 && k.is_finite()) {
            return Err(SampleError::Setting {
                name: "burn_multiple",
                reason: "must be finite and >= 0",
            });
        }
        self.burn_multiple = k;
        Ok(self)
    }

    /// Budget: most steps per ensemble (default 20,000).
    pub fn with_max_steps(mut self, n: usize) -> Result<Self, SampleError> {
        if n == 0 {
            return Err(SampleError::Setting {
                name: "max_steps",
                reason: "must be > 0",
            });
        }
        self.max_steps = n;
        Ok(self)
    }

    /// Stop by effective sample size instead of chain length: once the
    /// smallest ESS reaches `n` (and the stop rule's other conditions hold).
    pub fn with_ess(mut self, n: f64) -> Result<Self, SampleError> {
        if !(n >= 1.0 && n.is_finite()) {
            return Err(SampleError::Setting {
                name: "ess",
                reason: "must be a finite number >= 1",
            });
        }
        self.ess = Some(n);
        Ok(self)
    }

    /// The shortest kept chain, in autocorrelation times, whose estimate
    /// of `tau` the stop rule trusts (default [`TAU_TRUSTED`]). A shorter
    /// window gives a `tau` biased low, an ESS too large and Monte Carlo
    /// standard errors too small: `docs/inference.md` measures the claimed
    /// against the observed errors for several values.
    pub fn with_trust_multiple(mut self, k: f64) -> Result<Self, SampleError> {
        if !(k >= 1.0 && k.is_finite()) {
            return Err(SampleError::Setting {
                name: "trust_multiple",
                reason: "must be finite and >= 1",
            });
        }
        self.trust_multiple = k;
        Ok(self)
    }

    /// The moves, mixed by weight.
    pub fn with_moves(mut self, moves: Moves) -> Self {
        self.moves = moves;
        self
    }

    /// Centres of further basins of the posterior
    /// ([`crate::inference::basins`]): each ensemble's walkers are then
    /// started in turn around the MAP and around each of these, so that the
    /// draws reach every basin. The Gaussian independence move, fitted to
    /// walkers in several basins, proposes across them, so the share of
    /// each basin is the posterior's, not the start's. Default: none.
    pub fn with_basins(mut self, centres: Vec<Vec<f64>>) -> Self {
        self.basins = centres;
        self
    }

    /// The centres of further basins the walkers start around.
    pub fn basins(&self) -> &[Vec<f64>] {
        &self.basins
    }

    /// The moves.
    pub fn moves(&self) -> &Moves {
        &self.moves
    }

    /// Walkers per ensemble for a posterior of `dim` parameters.
    pub fn walkers_for(&self, dim: usize) -> usize {
        self.walkers.unwrap_or_else(|| {
            // The Gaussian move fits a covariance to the other half:
            // 4 dim walkers a half estimate it well enough to mix in
            // about 13 steps on the benchmark's Test 5 record, against
            // 33 with 2 dim (docs/inference.md).
            let n = 32.max(8 * dim);
            n + n % 2
        })
    }
}

/// Where a run stands, for progress displays.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Steps done per ensemble.
    pub steps: usize,
    /// The budget.
    pub max_steps: usize,
    /// Latest largest autocorrelation time (NaN before the first check).
    pub tau_max: f64,
    /// Steps the run needs at the latest estimate.
    pub target_steps: usize,
}

/// What became of the checkpoint folder at the start of a run.
///
/// Serialised internally tagged, kebab-case: `{"status": "none"}`,
/// `{"status": "fresh"}`, `{"status": "resumed", "steps": 300}`,
/// `{"status": "discarded", "reason": "..."}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "kebab-case")]
pub enum CheckpointStatus {
    /// No checkpoint folder was used.
    None,
    /// No checkpoint to resume: the run started afresh.
    Fresh,
    /// Resumed from a verified checkpoint of `steps` steps per ensemble.
    Resumed { steps: usize },
    /// A checkpoint was found but not resumed (corrupted, truncated, from
    /// another configuration or format): the run started afresh after
    /// deleting it. `reason` names the file and what was wrong.
    Discarded { reason: String },
}

impl std::fmt::Display for CheckpointStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::None => write!(f, "no checkpoint"),
            Self::Fresh => write!(f, "no checkpoint to resume; started afresh"),
            Self::Resumed { steps } => write!(f, "resumed from the checkpoint at step {steps}"),
            Self::Discarded { reason } => {
                write!(f, "checkpoint discarded, started afresh: {reason}")
            }
        }
    }
}

/// The posterior sample and its diagnostics.
#[derive(Debug, Clone)]
pub struct PosteriorSample {
    /// Parameter names.
    pub names: Vec<String>,
    /// One chain per ensemble, burn-in included.
    pub chains: Vec<Chain>,
    /// Burn-in steps (discarded from every summary).
    pub burn: usize,
    /// Autocorrelation time per ensemble and parameter (kept part).
    pub tau: Vec<Vec<f64>>,
    /// Effective sample size per parameter, summed over ensembles.
    pub ess: Vec<f64>,
    /// Rank-normalised split R-hat per parameter, across ensembles.
    pub rhat: Vec<f64>,
    /// Acceptance fraction per ensemble.
    pub acceptance: Vec<f64>,
    /// Whether the stop rule held: the kept chain at least `tau_multiple`
    /// (and the trust multiple, default [`TAU_TRUSTED`]) autocorrelation
    /// times long, or the ESS target reached, and split R-hat at most
    /// [`RHAT_MAX`] on every parameter.
    pub converged: bool,
    /// Why the run is not converged (empty when it is).
    pub not_converged: String,
    /// The moves, as `name:weight` joined by commas.
    pub moves: String,
    /// Log-density evaluations by the sampler over the whole run (resumed
    /// parts included; the starting ensembles not counted).
    pub evaluations: u64,
    /// Wall time of this process's part of the run (s).
    pub wall_time: f64,
    /// Whether the run resumed a checkpoint, started afresh, or discarded
    /// one (and why).
    pub checkpoint: CheckpointStatus,
}

impl PosteriorSample {
    /// Steps per ensemble.
    pub fn steps(&self) -> usize {
        self.chains.first().map_or(0, Chain::steps)
    }

    /// Pooled kept draws of each parameter: `draws[k]`.
    pub fn draws(&self) -> Vec<Vec<f64>> {
        (0..self.names.len())
            .map(|k| {
                let mut v = Vec::new();
                for c in &self.chains {
                    for s in self.burn..c.steps() {
                        for w in 0..c.walkers() {
                            v.push(c.get(s, w)[k]);
                        }
                    }
                }
                v
            })
            .collect()
    }

    /// Kept draws as points (step-major, ensemble after ensemble).
    pub fn points(&self) -> Vec<Vec<f64>> {
        let mut v = Vec::new();
        for c in &self.chains {
            for s in self.burn..c.steps() {
                for w in 0..c.walkers() {
                    v.push(c.get(s, w).to_vec());
                }
            }
        }
        v
    }

    /// Summary of each parameter.
    pub fn summaries(&self) -> Vec<ParamSummary> {
        self.draws()
            .par_iter()
            .map(|d| ParamSummary::from_draws(d))
            .collect()
    }
}

/// Per-coordinate conditional standard deviations at `center`: the step
/// along each axis (both ways, averaged) that lowers the log-density by 1/2,
/// found by doubling then bisection. `range[k]` bounds the search.
pub fn conditional_scales<D: LogDensity + ?Sized>(
    density: &D,
    center: &[f64],
    range: &[f64],
) -> Result<Vec<f64>, SamplerError> {
    let lp0 = density.ln_density(center)?;
    let mut out = Vec::with_capacity(center.len());
    for k in 0..center.len() {
        let mut sides = Vec::new();
        for sign in [1.0, -1.0] {
            let drop = |h: f64| -> Result<f64, SamplerError> {
                let mut x = center.to_vec();
                x[k] += sign * h;
                Ok(lp0 - density.ln_density(&x)?)
            };
            let (mut lo, mut hi) = (0.0, 1e-9 * range[k]);
            while drop(hi)? < 0.5 && hi < range[k] {
                lo = hi;
                hi *= 2.0;
            }
            if hi >= range[k] && drop(hi)? < 0.5 {
                sides.push(range[k]);
                continue;
            }
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if drop(mid)? < 0.5 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // A boundary (-inf) right next to the centre says nothing about
            // the width on that side.
            if lo > 0.0 {
                sides.push(0.5 * (lo + hi));
            }
        }
        let s = if sides.is_empty() {
            1e-6 * range[k]
        } else {
            sides.iter().sum::<f64>() / sides.len() as f64
        };
        out.push(s);
    }
    Ok(out)
}

/// splitmix64's finaliser: decorrelates nearby seeds (the sampler's
/// streams, a ground-motion suite's motions).
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn stream(seed: u64, ensemble: usize, chunk: u64) -> StdRng {
    StdRng::seed_from_u64(mix(mix(mix(seed) ^ ensemble as u64) ^ chunk))
}

/// Draws one ensemble, walker `w` around `centres[w % centres.len()]`.
fn start<D: LogDensity + ?Sized>(
    density: &D,
    centres: &[&[f64]],
    scale: &[f64],
    walkers: usize,
    seed: u64,
    e: usize,
) -> Result<Ensemble, SampleError> {
    let mut rng = stream(seed, e, u64::MAX);
    let dim = centres[0].len();
    for attempt in 0..20 {
        let shrink = 0.5f64.powi(attempt);
        let mut positions = Vec::with_capacity(walkers);
        let mut tries = 0;
        while positions.len() < walkers && tries < 1000 * walkers {
            tries += 1;
            let center = centres[positions.len() % centres.len()];
            let x: Vec<f64> = (0..dim)
                .map(|k| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    center[k] + shrink * scale[k] * z
                })
                .collect();
            if density.ln_density(&x)? > f64::NEG_INFINITY {
                positions.push(x);
            }
        }
        if positions.len() < walkers {
            continue;
        }
        match Ensemble::new(density, positions) {
            Ok(ens) => return Ok(ens),
            Err(SamplerError::Degenerate { .. }) | Err(SamplerError::Outside { .. }) => continue,
            Err(e) => return Err(e.into()),
        }
    }
    Err(SampleError::Start { walkers, dim })
}

/// Version of the checkpoint format (`state.json` and the chain files); a
/// checkpoint of another version is discarded.
const FORMAT_VERSION: u32 = 3;

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// 64-bit FNV-1a of `bytes`, continued from `h` (start at [`FNV_OFFSET`]).
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

#[derive(Debug, Serialize, Deserialize)]
struct State {
    version: u32,
    fingerprint: String,
    steps: usize,
    chunks: u64,
    accepted: Vec<Vec<u64>>,
    /// Per ensemble: what its chain file holds for the first `steps` steps.
    files: Vec<FileSum>,
    /// 64-bit FNV-1a of the fields above ([`state_sum`]), 16 hex digits: an
    /// edited acceptance count would otherwise be resumed as it stands.
    state_fnv1a: String,
}

/// The checksum of a state's content (steps, chunks, acceptance counts and
/// file sums, as compact JSON).
fn state_sum(steps: usize, chunks: u64, accepted: &[Vec<u64>], files: &[FileSum]) -> String {
    let body = serde_json::to_string(&(steps, chunks, accepted, files)).expect("state serialises");
    format!("{:016x}", fnv1a(FNV_OFFSET, body.as_bytes()))
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct FileSum {
    /// Length of the covered prefix (`steps * record` bytes).
    bytes: u64,
    /// 64-bit FNV-1a of those bytes, 16 hex digits.
    fnv1a: String,
}

/// What [`Checkpoint::restore`] found.
enum Restored {
    /// No state file.
    Missing,
    /// A checkpoint that must not be resumed, and why.
    Discarded(String),
    /// A verified checkpoint.
    Resumed {
        steps: usize,
        chunks: u64,
        chains: Vec<Chain>,
        /// Running checksum of each chain file.
        sums: Vec<u64>,
    },
}

/// A checkpoint folder: `state.json` and `ensemble-<e>.bin`.
struct Checkpoint {
    dir: PathBuf,
}

impl Checkpoint {
    fn err(&self, path: &Path, source: std::io::Error) -> SampleError {
        let _ = self;
        SampleError::Checkpoint {
            path: path.display().to_string(),
            source,
        }
    }

    fn chain_name(e: usize) -> String {
        format!("ensemble-{e}.bin")
    }

    fn chain_path(&self, e: usize) -> PathBuf {
        self.dir.join(Self::chain_name(e))
    }

    /// `file` as reported: the folder's own name, then the file's.
    fn label(&self, file: &str) -> String {
        match self.dir.file_name() {
            Some(d) => format!("{}/{file}", d.to_string_lossy()),
            None => self.dir.join(file).display().to_string(),
        }
    }

    /// Restores the chains if the state file exists, parses, is of this
    /// format and run, and every chain file holds exactly the bytes it
    /// records. A chain file longer than that (steps appended after the
    /// last state) is replaced by its verified prefix, by rename.
    fn restore(&self, fingerprint: &str, walkers: usize, dim: usize, ensembles: usize) -> Restored {
        let state_label = self.label("state.json");
        let path = self.dir.join("state.json");
        let text = match std::fs::read(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Restored::Missing,
            Err(e) => return Restored::Discarded(format!("{state_label} could not be read ({e})")),
        };
        let value: serde_json::Value = match serde_json::from_slice(&text) {
            Ok(v) => v,
            Err(e) => return Restored::Discarded(format!("{state_label} is not valid JSON ({e})")),
        };
        match value.get("version").and_then(serde_json::Value::as_u64) {
            Some(v) if v == FORMAT_VERSION as u64 => {}
            Some(v) => {
                return Restored::Discarded(format!(
                    "{state_label} has checkpoint format version {v}; this hbis reads version {FORMAT_VERSION}"
                ))
            }
            None => {
                return Restored::Discarded(format!(
                    "{state_label} has no checkpoint format version (an older hbis or another program wrote it)"
                ))
            }
        }
        let state: State = match serde_json::from_value(value) {
            Ok(s) => s,
            Err(e) => {
                return Restored::Discarded(format!(
                    "{state_label} lacks or mistypes checkpoint fields ({e})"
                ))
            }
        };
        if state.state_fnv1a != state_sum(state.steps, state.chunks, &state.accepted, &state.files)
        {
            return Restored::Discarded(format!(
                "{state_label}: its checksum does not match its content (edited or corrupted)"
            ));
        }
        if state.fingerprint != fingerprint {
            return Restored::Discarded(format!(
                "{} belongs to another configuration (seed, model, settings or record differ)",
                self.label("").trim_end_matches('/')
            ));
        }
        let record = walkers * (dim + 1) * 8;
        let want = match state.steps.checked_mul(record) {
            Some(w) if state.steps > 0 => w,
            _ => {
                return Restored::Discarded(format!(
                    "{state_label} records an impossible step count ({})",
                    state.steps
                ))
            }
        };
        if state.accepted.len() != ensembles
            || state.files.len() != ensembles
            || state
                .accepted
                .iter()
                .any(|a| a.len() != walkers || a.iter().any(|&n| n > state.steps as u64))
        {
            return Restored::Discarded(format!(
                "{state_label} does not describe {ensembles} ensembles of {walkers} walkers over {} steps",
                state.steps
            ));
        }
        let mut chains = Vec::with_capacity(ensembles);
        let mut sums = Vec::with_capacity(ensembles);
        for (e, (accepted, sum)) in state.accepted.iter().zip(&state.files).enumerate() {
            let label = self.label(&Self::chain_name(e));
            let expected = match u64::from_str_radix(&sum.fnv1a, 16) {
                Ok(h) if sum.bytes == want as u64 && sum.fnv1a.len() == 16 => h,
                _ => {
                    return Restored::Discarded(format!(
                        "{state_label}: the record of {label} is malformed"
                    ))
                }
            };
            let p = self.chain_path(e);
            let mut f = match File::open(&p) {
                Ok(f) => f,
                Err(x) => return Restored::Discarded(format!("{label} could not be opened ({x})")),
            };
            let len = match f.metadata() {
                Ok(m) => m.len(),
                Err(x) => return Restored::Discarded(format!("{label} could not be read ({x})")),
            };
            if len < want as u64 {
                return Restored::Discarded(format!(
                    "{label} is {len} bytes long, shorter than the {want} bytes of the {} steps in state.json (file truncated)",
                    state.steps
                ));
            }
            let mut bytes = vec![0u8; want];
            if let Err(x) = f.read_exact(&mut bytes) {
                return Restored::Discarded(format!("{label} could not be read ({x})"));
            }
            drop(f);
            let h = fnv1a(FNV_OFFSET, &bytes);
            if h != expected {
                return Restored::Discarded(format!(
                    "{label}: checksum of the first {} steps does not match state.json (file corrupted)",
                    state.steps
                ));
            }
            let values: Vec<f64> = bytes
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
                .collect();
            let (mut samples, mut lp) = (
                Vec::with_capacity(state.steps * walkers * dim),
                Vec::with_capacity(state.steps * walkers),
            );
            for step in values.chunks_exact(walkers * (dim + 1)) {
                samples.extend_from_slice(&step[..walkers * dim]);
                lp.extend_from_slice(&step[walkers * dim..]);
            }
            if let Some(i) = samples.iter().position(|v| !v.is_finite()) {
                return Restored::Discarded(format!(
                    "{label}: position at step {} is not finite (file corrupted)",
                    i / (walkers * dim)
                ));
            }
            if let Some(i) = lp.iter().position(|v| !v.is_finite()) {
                return Restored::Discarded(format!(
                    "{label}: log-probability at step {} is not finite (file corrupted)",
                    i / walkers
                ));
            }
            if len > want as u64 {
                // Steps appended after the last state: keep the verified
                // prefix, written to a new file renamed into place.
                if let Err(x) = self.replace(&p, &bytes) {
                    return Restored::Discarded(format!(
                        "{label}: could not drop the {} bytes written after state.json ({x})",
                        len - want as u64
                    ));
                }
            }
            chains.push(Chain::from_parts(
                walkers,
                dim,
                samples,
                lp,
                accepted.clone(),
            ));
            sums.push(h);
        }
        Restored::Resumed {
            steps: state.steps,
            chunks: state.chunks,
            chains,
            sums,
        }
    }

    /// Replaces `path` with a file holding `bytes`: written to a temporary
    /// file, synced, renamed over it.
    fn replace(&self, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        let _ = self;
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        {
            let mut f = File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_all()?;
        }
        std::fs::rename(&tmp, path)
    }

    /// Deletes the state and every chain file (any index), for a fresh run.
    fn clear(&self) -> Result<(), SampleError> {
        let remove = |p: &Path| match std::fs::remove_file(p) {
            Err(x) if x.kind() != std::io::ErrorKind::NotFound => Err(self.err(p, x)),
            _ => Ok(()),
        };
        // The state first: without it nothing left behind is resumed.
        remove(&self.dir.join("state.json"))?;
        remove(&self.dir.join("state.json.tmp"))?;
        let entries = match std::fs::read_dir(&self.dir) {
            Ok(r) => r,
            Err(x) if x.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            Err(x) => return Err(self.err(&self.dir, x)),
        };
        for entry in entries {
            let entry = entry.map_err(|x| self.err(&self.dir, x))?;
            let name = entry.file_name();
            let name = name.to_string_lossy();
            let stem = name
                .strip_suffix(".bin")
                .or_else(|| name.strip_suffix(".bin.tmp"))
                .and_then(|s| s.strip_prefix("ensemble-"));
            if stem.is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())) {
                remove(&entry.path())?;
            }
        }
        Ok(())
    }

    /// Appends the new steps of each chain (continuing each file's checksum
    /// in `sums`), then replaces the state file.
    fn save(
        &self,
        fingerprint: &str,
        chunks: u64,
        chains: &[Chain],
        from_step: usize,
        sums: &mut [u64],
    ) -> Result<(), SampleError> {
        std::fs::create_dir_all(&self.dir).map_err(|x| self.err(&self.dir, x))?;
        let mut files = Vec::with_capacity(chains.len());
        for (e, c) in chains.iter().enumerate() {
            let p = self.chain_path(e);
            let mut f = OpenOptions::new()
                .create(true)
                .append(true)
                .open(&p)
                .map_err(|x| self.err(&p, x))?;
            let mut bytes =
                Vec::with_capacity((c.steps() - from_step) * c.walkers() * (c.dim() + 1) * 8);
            for s in from_step..c.steps() {
                for w in 0..c.walkers() {
                    for v in c.get(s, w) {
                        bytes.extend_from_slice(&v.to_le_bytes());
                    }
                }
                for w in 0..c.walkers() {
                    bytes.extend_from_slice(&c.log_prob_at(s, w).to_le_bytes());
                }
            }
            f.write_all(&bytes).map_err(|x| self.err(&p, x))?;
            f.sync_data().map_err(|x| self.err(&p, x))?;
            sums[e] = fnv1a(sums[e], &bytes);
            files.push(FileSum {
                bytes: (c.steps() * c.walkers() * (c.dim() + 1) * 8) as u64,
                fnv1a: format!("{:016x}", sums[e]),
            });
        }
        let (steps, accepted) = (
            chains[0].steps(),
            chains
                .iter()
                .map(|c| c.accepted().to_vec())
                .collect::<Vec<_>>(),
        );
        let state = State {
            version: FORMAT_VERSION,
            fingerprint: fingerprint.to_string(),
            state_fnv1a: state_sum(steps, chunks, &accepted, &files),
            steps,
            chunks,
            accepted,
            files,
        };
        let tmp = self.dir.join("state.json.tmp");
        let text = serde_json::to_string(&state).expect("state serialises");
        {
            let mut f = File::create(&tmp).map_err(|x| self.err(&tmp, x))?;
            f.write_all(text.as_bytes())
                .map_err(|x| self.err(&tmp, x))?;
            f.sync_data().map_err(|x| self.err(&tmp, x))?;
        }
        let path = self.dir.join("state.json");
        std::fs::rename(&tmp, &path).map_err(|x| self.err(&path, x))
    }
}

/// A fingerprint of everything that determines a run, so that a checkpoint
/// is only resumed by the same run.
fn fingerprint(
    seed: u64,
    settings: &SampleSettings,
    names: &[String],
    center: &[f64],
    scale: &[f64],
    extra: &str,
) -> String {
    let mut h = FNV_OFFSET;
    let mut eat = |bytes: &[u8]| h = fnv1a(h, bytes);
    eat(&seed.to_le_bytes());
    // The budget and the trust multiple are left out: a run may be resumed
    // with a larger budget, and neither changes a step of the chains.
    let s = settings;
    eat(format!(
        "{:?} {} {} {} {} {:?} {}",
        s.walkers, s.ensembles, s.chunk, s.tau_multiple, s.burn_multiple, s.ess, s.moves
    )
    .as_bytes());
    for n in names {
        eat(n.as_bytes());
    }
    for v in center.iter().chain(scale).chain(s.basins.iter().flatten()) {
        eat(&v.to_le_bytes());
    }
    eat(extra.as_bytes());
    format!("{h:016x}")
}

/// Samples the posterior `density` from `center` (the MAP).
///
/// `scale` sets the starting ball (see [`conditional_scales`]); `checkpoint`
/// is a folder to save to and resume from; `extra` joins the checkpoint's
/// fingerprint (e.g. the model and the record's name).
#[allow(clippy::too_many_arguments)]
pub fn sample_posterior<D: LogDensity + ?Sized>(
    density: &D,
    names: &[String],
    center: &[f64],
    scale: &[f64],
    settings: &SampleSettings,
    seed: u64,
    checkpoint: Option<&Path>,
    extra: &str,
    progress: &mut dyn FnMut(Progress),
) -> Result<PosteriorSample, SampleError> {
    let clock = Instant::now();
    let dim = density.dim();
    let walkers = settings.walkers_for(dim);
    let fp = fingerprint(seed, settings, names, center, scale, extra);
    let cp = checkpoint.map(|d| Checkpoint {
        dir: d.to_path_buf(),
    });
    let restored = match &cp {
        Some(cp) => cp.restore(&fp, walkers, dim, settings.ensembles),
        None => Restored::Missing,
    };
    let sampler = EnsembleSampler::new(settings.moves.clone());
    let (status, mut chains, mut ensembles, mut chunks, mut sums) = match restored {
        Restored::Resumed {
            steps,
            chunks,
            chains,
            sums,
        } => {
            let ensembles: Vec<Ensemble> = chains
                .iter()
                .map(|c| {
                    let last = c.steps() - 1;
                    Ensemble::from_parts(
                        (0..walkers).map(|w| c.get(last, w).to_vec()).collect(),
                        (0..walkers).map(|w| c.log_prob_at(last, w)).collect(),
                    )
                })
                .collect();
            (
                CheckpointStatus::Resumed { steps },
                chains,
                ensembles,
                chunks,
                sums,
            )
        }
        fresh => {
            let status = match (&cp, fresh) {
                (None, _) => CheckpointStatus::None,
                (Some(_), Restored::Discarded(reason)) => CheckpointStatus::Discarded { reason },
                (Some(_), _) => CheckpointStatus::Fresh,
            };
            if let Some(cp) = &cp {
                // A fresh run: whatever the folder holds is stale.
                cp.clear()?;
            }
            let centres: Vec<&[f64]> = std::iter::once(center)
                .chain(settings.basins.iter().map(Vec::as_slice))
                .collect();
            let ensembles = (0..settings.ensembles)
                .into_par_iter()
                .map(|e| {
                    // Walkers split between basins far apart may not span
                    // every dimension well enough to start; the MAP's
                    // basin alone then (the basins' shares will show it).
                    start(density, &centres, scale, walkers, seed, e).or_else(|err| {
                        if centres.len() > 1 {
                            start(density, &centres[..1], scale, walkers, seed, e)
                        } else {
                            Err(err)
                        }
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            (
                status,
                vec![Chain::new(walkers, dim); settings.ensembles],
                ensembles,
                0,
                vec![FNV_OFFSET; settings.ensembles],
            )
        }
    };
    // A resumed run needs the estimate of the last check it passed, as the
    // uninterrupted run has it.
    let mut tau_max = match last_check(chains[0].steps(), settings.chunk) {
        Some(c) if c < chains[0].steps() => max_tau_range(&chains, c / 2, c),
        _ => f64::NAN,
    };
    let mut verdict = Verdict::default();
    loop {
        let steps = chains[0].steps();
        if is_check(steps, settings.chunk) {
            let half = all_taus(&chains, steps / 2);
            tau_max = largest(&half);
            verdict = stop_rule(&chains, half, settings, steps);
        }
        let converged = verdict.converged;
        let target = target_steps(settings, tau_max, walkers * chains.len());
        progress(Progress {
            steps,
            max_steps: settings.max_steps,
            tau_max,
            target_steps: target,
        });
        if converged || steps >= settings.max_steps {
            break;
        }
        let n = settings.chunk.min(settings.max_steps - steps);
        let parts = ensembles
            .par_iter_mut()
            .enumerate()
            .map(|(e, ens)| {
                let mut rng = stream(seed, e, chunks);
                sampler.run(ens, density, n, &mut rng)
            })
            .collect::<Result<Vec<_>, _>>()?;
        for (c, p) in chains.iter_mut().zip(&parts) {
            c.extend(p);
        }
        chunks += 1;
        if let Some(cp) = &cp {
            cp.save(&fp, chunks, &chains, steps, &mut sums)?;
        }
    }
    let steps = chains[0].steps();
    let burn = burn_in(tau_max, settings, steps);
    // A converged run stopped at the check that computed its R-hat and its
    // taus on these very steps.
    let tau = match verdict.tau.take() {
        Some(t) if verdict.converged => t,
        _ => all_taus(&chains, burn),
    };
    let ess = ess_of(&tau, steps - burn, walkers, dim);
    let rhat = match verdict.rhat.take() {
        Some(r) if verdict.converged => r,
        _ => rhats(&chains, burn, dim),
    };
    let (converged, not_converged) = if verdict.converged {
        (true, String::new())
    } else if verdict.reason.is_empty() {
        (
            false,
            format!("budget of {steps} steps spent before the first check"),
        )
    } else {
        (
            false,
            format!("budget of {steps} steps spent: {}", verdict.reason),
        )
    };
    Ok(PosteriorSample {
        names: names.to_vec(),
        acceptance: chains.iter().map(Chain::acceptance_fraction).collect(),
        chains,
        burn,
        tau,
        ess,
        rhat,
        converged,
        not_converged,
        moves: settings.moves.to_string(),
        evaluations: (steps * walkers * settings.ensembles) as u64,
        wall_time: clock.elapsed().as_secs_f64(),
        checkpoint: status,
    })
}

/// The stop rule's state at the last check.
#[derive(Debug, Default)]
struct Verdict {
    converged: bool,
    reason: String,
    /// R-hat per parameter, when the check computed it.
    rhat: Option<Vec<f64>>,
    /// `tau[e][k]` on the kept steps of the last check.
    tau: Option<Vec<Vec<f64>>>,
}

/// Effective sample size per parameter, summed over ensembles.
fn ess_of(tau: &[Vec<f64>], kept_steps: usize, walkers: usize, dim: usize) -> Vec<f64> {
    let kept = kept_steps as f64 * walkers as f64;
    (0..dim)
        .map(|k| tau.iter().map(|t| kept / t[k]).sum())
        .collect()
}

/// Split R-hat per parameter on the kept steps, on at most ~20,000 draws
/// per ensemble (evenly thinned steps): ranks of a million draws per
/// parameter would cost more than they tell, since consecutive steps are
/// strongly correlated anyway.
fn rhats(chains: &[Chain], burn: usize, dim: usize) -> Vec<f64> {
    let (steps, walkers) = (chains[0].steps(), chains[0].walkers());
    let stride = ((steps - burn) * walkers).div_ceil(20_000).max(1);
    (0..dim)
        .into_par_iter()
        .map(|k| {
            let seqs: Vec<Vec<f64>> = chains
                .iter()
                .map(|c| {
                    (burn..c.steps())
                        .step_by(stride)
                        .flat_map(|s| (0..walkers).map(move |w| (s, w)))
                        .map(|(s, w)| c.get(s, w)[k])
                        .collect()
                })
                .collect();
            split_rhat(&seqs)
        })
        .collect()
}

/// The stop rule at a check: the kept chain long enough for its own `tau`
/// estimate to be trusted (`trust_multiple` times it), then either
/// `tau_multiple` times `tau` long or the ESS target reached, and split
/// R-hat at most [`RHAT_MAX`] on every parameter. Burn-in comes from the
/// largest of `half`, the estimates on the second half; every condition
/// is judged with `tau` estimated on the kept steps themselves, the window
/// it is about (`half` again when the burn-in is the first half). The
/// reason lists every condition that fails, with its numbers.
fn stop_rule(
    chains: &[Chain],
    half: Vec<Vec<f64>>,
    settings: &SampleSettings,
    steps: usize,
) -> Verdict {
    let burn = burn_in(largest(&half), settings, steps);
    let kept = (steps - burn) as f64;
    let dim = chains[0].dim();
    let tau = if burn == steps / 2 {
        half
    } else {
        all_taus(chains, burn)
    };
    let tau_kept = largest(&tau);
    let mut reasons = Vec::new();
    let trust = settings.trust_multiple;
    if !at_least(kept, trust * tau_kept) {
        reasons.push(format!(
            "kept chain {kept:.0} steps, shorter than {trust} x the autocorrelation time estimate {tau_kept:.1} needed to trust it"
        ));
    }
    match settings.ess {
        Some(target) => {
            let ess = ess_of(&tau, steps - burn, chains[0].walkers(), dim);
            let least = ess.iter().copied().fold(f64::INFINITY, f64::min);
            if !at_least(least, target) {
                reasons.push(format!("smallest ESS {least:.0} < {target:.0}"));
            }
        }
        None => {
            if !at_least(kept, settings.tau_multiple * tau_kept) {
                reasons.push(format!(
                    "kept chain {kept:.0} steps < {} x tau {tau_kept:.1}",
                    settings.tau_multiple
                ));
            }
        }
    }
    // R-hat only once the rest holds: it is the costliest check.
    let mut rhat = None;
    if reasons.is_empty() {
        let r = rhats(chains, burn, dim);
        // A NaN R-hat counts as the worst.
        let worst = r
            .iter()
            .map(|&x| if x.is_nan() { f64::INFINITY } else { x })
            .fold(0.0, f64::max);
        if !at_least(RHAT_MAX, worst) {
            reasons.push(format!("largest split R-hat {worst:.4} > {RHAT_MAX}"));
        }
        rhat = Some(r);
    }
    Verdict {
        converged: reasons.is_empty(),
        reason: reasons.join("; "),
        rhat,
        tau: Some(tau),
    }
}

/// Steps per ensemble the stop rule needs if the autocorrelation time
/// stays `tau` (the budget while it is unknown), for a progress display:
/// burn-in plus the kept chain that the rule asks for, `draws_per_step`
/// being the walkers of all ensembles.
///
/// # Formula
///
/// `burn_multiple tau + max(trust tau, K tau)`, with `K` the tau multiple,
/// or under an ESS target `N` (the ESS summed over ensembles is
/// `kept draws_per_step / tau`) `K = N / draws_per_step`; at most
/// `max_steps`.
fn target_steps(settings: &SampleSettings, tau: f64, draws_per_step: usize) -> usize {
    if !tau.is_finite() {
        return settings.max_steps;
    }
    let multiple = match settings.ess {
        Some(n) => n / draws_per_step.max(1) as f64,
        None => settings.tau_multiple,
    };
    let steps = (settings.burn_multiple + multiple.max(settings.trust_multiple)) * tau;
    (steps.ceil() as usize).min(settings.max_steps)
}

/// `a >= b`, false when either is NaN (a condition a NaN cannot meet).
fn at_least(a: f64, b: f64) -> bool {
    a >= b
}

/// Checks fall at `c_0 = chunk`, `c_(i+1) = c_i + max(chunk, c_i/5)`
/// (rounded to chunks): a function of the step count alone, so a resumed
/// run checks where an uninterrupted one does.
fn is_check(steps: usize, chunk: usize) -> bool {
    let mut c = chunk;
    while c < steps {
        c += chunk.max((c / 5) / chunk * chunk);
    }
    c == steps
}

/// The last check at or before `steps`, if any.
fn last_check(steps: usize, chunk: usize) -> Option<usize> {
    let mut last = None;
    let mut c = chunk;
    while c <= steps {
        last = Some(c);
        c += chunk.max((c / 5) / chunk * chunk);
    }
    last
}

/// The largest of `tau[e][k]`.
fn largest(tau: &[Vec<f64>]) -> f64 {
    tau.iter().flatten().copied().fold(0.0, f64::max)
}

fn max_tau_range(chains: &[Chain], from: usize, to: usize) -> f64 {
    let tau: Vec<Vec<f64>> = chains
        .par_iter()
        .map(|c| {
            (0..c.dim())
                .into_par_iter()
                .map(|k| effective_time(&c.series_range(k, from, to)))
                .collect()
        })
        .collect();
    largest(&tau)
}

/// `tau[e][k]` of every ensemble and parameter, in parallel (each value is
/// computed alone, so the result does not depend on the thread count).
fn all_taus(chains: &[Chain], from: usize) -> Vec<Vec<f64>> {
    chains
        .par_iter()
        .map(|c| {
            (0..c.dim())
                .into_par_iter()
                .map(|k| effective_time(&c.series(k, from)))
                .collect()
        })
        .collect()
}

fn burn_in(tau_max: f64, settings: &SampleSettings, steps: usize) -> usize {
    if tau_max.is_finite() {
        ((settings.burn_multiple * tau_max).ceil() as usize).min(steps / 2)
    } else {
        steps / 2
    }
}

#[cfg(test)]
mod tests {
    /// The progress target follows the rule that stops the run: the tau
    /// multiple, or under `--ess` the kept chain that ESS needs (it
    /// projected from the tau multiple before).
    #[test]
    fn the_progress_target_follows_the_stop_rule() {
        let s = SampleSettings::default();
        // burn 5 tau + 50 tau.
        assert_eq!(super::target_steps(&s, 10.0, 192), 550);
        assert_eq!(super::target_steps(&s, f64::NAN, 192), 20_000);
        // ESS 100,000 with 192 draws per step: 520.8 tau kept.
        let e = s.clone().with_ess(100_000.0).unwrap();
        assert_eq!(super::target_steps(&e, 10.0, 192), 5_259);
        // A small ESS target: the trust multiple (5 tau) binds.
        let e = s.clone().with_ess(100.0).unwrap();
        assert_eq!(super::target_steps(&e, 10.0, 192), 100);
        // Never past the budget.
        assert_eq!(super::target_steps(&s, 1e6, 192), 20_000);
    }

    use super::*;
    use crate::inference::ensemble::FnDensity;

    fn gaussian() -> FnDensity<impl Fn(&[f64]) -> f64 + Sync> {
        FnDensity::new(3, |x: &[f64]| {
            -0.5 * ((x[0] - 1.0).powi(2) / 0.04 + (x[1] + x[0]).powi(2) + x[2] * x[2] / 9.0)
        })
    }

    fn names() -> Vec<String> {
        ["a", "b", "c"].iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn conditional_scales_of_a_gaussian() {
        let s = conditional_scales(&gaussian(), &[1.0, -1.0, 0.0], &[10.0; 3]).unwrap();
        // Conditional sds: 1/sqrt(precision_kk) = 1/sqrt(25 + 1), 1, 3.
        assert!((s[0] - (1.0f64 / 26.0).sqrt()).abs() < 1e-6, "{s:?}");
        assert!((s[1] - 1.0).abs() < 1e-6 && (s[2] - 3.0).abs() < 1e-6);
    }

    #[test]
    fn converges_and_resumes_to_the_same_result() {
        let d = gaussian();
        let settings = SampleSettings::default().with_chunk(50).unwrap();
        let run = |dir: Option<&Path>, max: usize| {
            let s = settings.clone().with_max_steps(max).unwrap();
            sample_posterior(
                &d,
                &names(),
                &[1.0, -1.0, 0.0],
                &[0.2, 1.0, 3.0],
                &s,
                9,
                dir,
                "",
                &mut |_| {},
            )
            .unwrap()
        };
        let whole = run(None, 20_000);
        assert!(whole.converged);
        assert!(whole.rhat.iter().all(|r| *r < 1.01), "{:?}", whole.rhat);
        let sum = whole.summaries();
        assert!((sum[0].mean - 1.0).abs() < 0.01 && (sum[2].sd - 3.0).abs() < 0.1);
        // Interrupted after 50 and 100 steps (budgets), then resumed (the
        // default moves converge on this Gaussian within a few hundred).
        assert!(whole.steps() > 100, "{}", whole.steps());
        let dir = tempfile::tempdir().unwrap();
        let part = run(Some(dir.path()), 50);
        assert_eq!(part.steps(), 50);
        assert_eq!(part.checkpoint, CheckpointStatus::Fresh);
        let more = run(Some(dir.path()), 100);
        assert_eq!(more.checkpoint, CheckpointStatus::Resumed { steps: 50 });
        let resumed = run(Some(dir.path()), 20_000);
        assert_eq!(resumed.checkpoint, CheckpointStatus::Resumed { steps: 100 });
        assert_eq!(whole.checkpoint, CheckpointStatus::None);
        assert_eq!(resumed.chains, whole.chains);
        assert_eq!(resumed.burn, whole.burn);
        assert_eq!(resumed.summaries(), whole.summaries());
        assert_eq!(
            (resumed.ess.clone(), resumed.rhat.clone()),
            (whole.ess.clone(), whole.rhat.clone())
        );
        assert_eq!(resumed.evaluations, whole.evaluations);
    }

    // The checkpoint tests: 4 ensembles of 32 walkers in 3 dimensions, so a
    // step is 32 * 4 * 8 = 1024 bytes of each chain file.
    const RECORD: usize = 32 * 4 * 8;

    /// The stretch move alone: slow enough that the checkpoint tests'
    /// budgets end before convergence.
    /// Four ensembles (the tests below corrupt four chain files) in
    /// chunks of 50 steps.
    fn small_settings() -> SampleSettings {
        SampleSettings::default()
            .with_ensembles(4)
            .unwrap()
            .with_chunk(50)
            .unwrap()
            .with_moves(Moves::parse("stretch").unwrap())
    }

    fn run_small(dir: Option<&Path>, max: usize, seed: u64) -> PosteriorSample {
        let s = small_settings().with_max_steps(max).unwrap();
        sample_posterior(
            &gaussian(),
            &names(),
            &[1.0, -1.0, 0.0],
            &[0.2, 1.0, 3.0],
            &s,
            seed,
            dir,
            "",
            &mut |_| {},
        )
        .unwrap()
    }

    fn assert_same(a: &PosteriorSample, b: &PosteriorSample) {
        assert_eq!(a.chains, b.chains);
        assert_eq!(a.burn, b.burn);
        assert_eq!(a.summaries(), b.summaries());
        assert_eq!((&a.tau, &a.ess, &a.rhat), (&b.tau, &b.ess, &b.rhat));
        assert_eq!(a.acceptance, b.acceptance);
        assert_eq!((a.converged, a.evaluations), (b.converged, b.evaluations));
    }

    #[test]
    fn a_converged_run_reports_the_r_hat_of_its_kept_steps() {
        // The R-hat of the stopping check is reused: it must be that of
        // the steps kept in the end.
        let s = run_small(None, 20_000, 5);
        assert!(s.converged, "{}", s.not_converged);
        assert_eq!(s.rhat, rhats(&s.chains, s.burn, 3));
    }

    fn discarded(s: &PosteriorSample) -> &str {
        match &s.checkpoint {
            CheckpointStatus::Discarded { reason } => reason,
            other => panic!("expected a discarded checkpoint, got {other:?}"),
        }
    }

    /// A folder named `checkpoint` inside a temporary one, holding a
    /// 200-step run (seed 9) that is to be continued to 300 steps.
    fn checkpointed() -> (tempfile::TempDir, PathBuf) {
        let d = tempfile::tempdir().unwrap();
        let cp = d.path().join("checkpoint");
        let first = run_small(Some(&cp), 200, 9);
        assert_eq!(first.checkpoint, CheckpointStatus::Fresh);
        for e in 0..4 {
            let len = std::fs::metadata(cp.join(format!("ensemble-{e}.bin")))
                .unwrap()
                .len();
            assert_eq!(len, (200 * RECORD) as u64);
        }
        (d, cp)
    }

    fn patch(path: &Path, offset: usize, bytes: &[u8]) {
        let mut data = std::fs::read(path).unwrap();
        data[offset..offset + bytes.len()].copy_from_slice(bytes);
        std::fs::write(path, data).unwrap();
    }

    /// After a run of 300 steps the chain files hold exactly its 300 steps.
    fn assert_files_hold(cp: &Path, sample: &PosteriorSample) {
        for (e, c) in sample.chains.iter().enumerate() {
            let data = std::fs::read(cp.join(format!("ensemble-{e}.bin"))).unwrap();
            assert_eq!(data.len(), c.steps() * RECORD, "ensemble-{e}.bin");
            let mut want = Vec::new();
            for s in 0..c.steps() {
                for w in 0..c.walkers() {
                    for v in c.get(s, w) {
                        want.extend_from_slice(&v.to_le_bytes());
                    }
                }
                for w in 0..c.walkers() {
                    want.extend_from_slice(&c.log_prob_at(s, w).to_le_bytes());
                }
            }
            assert!(data == want, "ensemble-{e}.bin differs from the chain");
        }
    }

    #[test]
    fn garbage_in_a_chain_file_discards_the_checkpoint() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        // 0xff... is a NaN: the old code read it and gave NaN means.
        patch(&cp.join("ensemble-0.bin"), 100 * RECORD + 40, &[0xff; 3000]);
        let again = run_small(Some(&cp), 300, 9);
        let reason = discarded(&again);
        assert!(
            reason.contains("checkpoint/ensemble-0.bin")
                && reason.contains("checksum of the first 200 steps"),
            "{reason}"
        );
        assert!(again.summaries().iter().all(|s| s.mean.is_finite()));
        assert_same(&again, &fresh);
        assert_files_hold(&cp, &again);
    }

    #[test]
    fn a_block_copied_within_a_chain_file_discards_the_checkpoint() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        let p = cp.join("ensemble-1.bin");
        let data = std::fs::read(&p).unwrap();
        // Ten valid steps copied over ten others: every value stays finite.
        patch(&p, 120 * RECORD, &data[10 * RECORD..20 * RECORD]);
        let again = run_small(Some(&cp), 300, 9);
        let reason = discarded(&again);
        assert!(
            reason.contains("checkpoint/ensemble-1.bin") && reason.contains("file corrupted"),
            "{reason}"
        );
        assert_same(&again, &fresh);
    }

    #[test]
    fn a_truncated_chain_file_is_discarded_and_left_as_it_is() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        let p = cp.join("ensemble-2.bin");
        let f = OpenOptions::new().write(true).open(&p).unwrap();
        f.set_len((120 * RECORD + 17) as u64).unwrap();
        drop(f);
        // Inspecting the checkpoint leaves the file as it is.
        let fp = fingerprint(
            9,
            &small_settings(),
            &names(),
            &[1.0, -1.0, 0.0],
            &[0.2, 1.0, 3.0],
            "",
        );
        let c = Checkpoint { dir: cp.clone() };
        assert!(matches!(
            c.restore(&fp, 32, 3, 4),
            Restored::Discarded(r) if r.contains("checkpoint/ensemble-2.bin") && r.contains("truncated")
        ));
        assert_eq!(
            std::fs::metadata(&p).unwrap().len(),
            (120 * RECORD + 17) as u64
        );
        // The run starts afresh (the old code zero-extended the file and
        // failed on it forever).
        let again = run_small(Some(&cp), 300, 9);
        assert!(
            discarded(&again).contains("truncated"),
            "{:?}",
            again.checkpoint
        );
        assert_same(&again, &fresh);
        assert_files_hold(&cp, &again);
    }

    #[test]
    fn a_checkpoint_of_another_run_is_discarded() {
        let (_d, cp) = checkpointed();
        let other = run_small(Some(&cp), 300, 10);
        let reason = discarded(&other);
        assert!(reason.contains("another configuration"), "{reason}");
        assert_same(&other, &run_small(None, 300, 10));
        assert_files_hold(&cp, &other);
    }

    #[test]
    fn a_garbage_or_old_state_file_is_discarded() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        let state = cp.join("state.json");
        let good = std::fs::read_to_string(&state).unwrap();
        std::fs::write(&state, "\u{0}\u{7}garbage{").unwrap();
        let again = run_small(Some(&cp), 300, 9);
        let reason = discarded(&again);
        assert!(
            reason.contains("checkpoint/state.json is not valid JSON"),
            "{reason}"
        );
        assert_same(&again, &fresh);
        // A state without a format version (as the previous format wrote).
        let (_d2, cp) = checkpointed();
        let mut v: serde_json::Value = serde_json::from_str(&good).unwrap();
        v.as_object_mut().unwrap().remove("version");
        std::fs::write(cp.join("state.json"), v.to_string()).unwrap();
        let again = run_small(Some(&cp), 300, 9);
        assert!(
            discarded(&again).contains("no checkpoint format version"),
            "{:?}",
            again.checkpoint
        );
        assert_same(&again, &fresh);
    }

    /// Sets a state's own checksum to match its (edited) content.
    fn forge_state_sum(v: &mut serde_json::Value) {
        let files: Vec<FileSum> = serde_json::from_value(v["files"].clone()).unwrap();
        let accepted: Vec<Vec<u64>> = serde_json::from_value(v["accepted"].clone()).unwrap();
        let steps = v["steps"].as_u64().unwrap() as usize;
        let chunks = v["chunks"].as_u64().unwrap();
        v["state_fnv1a"] = state_sum(steps, chunks, &accepted, &files).into();
    }

    /// Issue 37: `accepted` was outside every checksum, so an edited count
    /// was resumed (and changed the reported acceptance) as it stood.
    #[test]
    fn an_edited_acceptance_count_is_discarded() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        let state = cp.join("state.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
        let n = v["accepted"][1][0].as_u64().unwrap();
        v["accepted"][1][0] = (n ^ 1).into();
        std::fs::write(&state, v.to_string()).unwrap();
        let again = run_small(Some(&cp), 300, 9);
        let reason = discarded(&again);
        assert!(
            reason.contains("checkpoint/state.json: its checksum does not match its content"),
            "{reason}"
        );
        assert_same(&again, &fresh);
    }

    #[test]
    fn non_finite_values_under_a_matching_checksum_are_discarded() {
        let fresh = run_small(None, 300, 9);
        let (_d, cp) = checkpointed();
        // A NaN position, with the state's checksum forged to match it.
        let p = cp.join("ensemble-3.bin");
        patch(&p, 150 * RECORD + 8, &f64::NAN.to_le_bytes());
        let sum = fnv1a(FNV_OFFSET, &std::fs::read(&p).unwrap());
        let state = cp.join("state.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
        v["files"][3]["fnv1a"] = format!("{sum:016x}").into();
        forge_state_sum(&mut v);
        std::fs::write(&state, v.to_string()).unwrap();
        let again = run_small(Some(&cp), 300, 9);
        let reason = discarded(&again);
        assert!(
            reason.contains("checkpoint/ensemble-3.bin: position at step 150 is not finite"),
            "{reason}"
        );
        assert_same(&again, &fresh);
    }

    /// A run killed after appending a chunk but before replacing the state
    /// (here: the files of a 250-step run, one with half a step more, under
    /// the state of the 200-step run) resumes from the state and drops the
    /// extra bytes by writing a new file.
    #[test]
    fn steps_appended_after_the_state_are_dropped_and_the_run_resumes() {
        let whole = run_small(None, 300, 9);
        let (d, cp) = checkpointed();
        let ahead = d.path().join("ahead");
        run_small(Some(&ahead), 250, 9);
        for e in 0..4 {
            let name = format!("ensemble-{e}.bin");
            let mut data = std::fs::read(ahead.join(&name)).unwrap();
            if e == 2 {
                data.extend_from_slice(&[0xab; RECORD / 2]);
            }
            // Written beside and renamed in, so that the tests do not share
            // an inode with the folder they read.
            std::fs::write(cp.join("new.bin"), &data).unwrap();
            std::fs::rename(cp.join("new.bin"), cp.join(&name)).unwrap();
        }
        // A second name for the old file sees whether it is changed in place.
        let link = d.path().join("link.bin");
        std::fs::hard_link(cp.join("ensemble-2.bin"), &link).unwrap();
        let resumed = run_small(Some(&cp), 300, 9);
        assert_eq!(resumed.checkpoint, CheckpointStatus::Resumed { steps: 200 });
        assert_eq!(
            std::fs::metadata(&link).unwrap().len(),
            (250 * RECORD + RECORD / 2) as u64,
            "the file was truncated in place"
        );
        assert_same(&resumed, &whole);
        assert_files_hold(&cp, &resumed);
        assert!(!cp.join("ensemble-2.bin.tmp").exists());
    }

    /// A fresh start deletes every chain file and the state, whatever the
    /// index, before writing its own.
    #[test]
    fn a_fresh_start_removes_every_old_chain_file() {
        let (_d, cp) = checkpointed();
        std::fs::write(cp.join("ensemble-7.bin"), [1u8; 10]).unwrap();
        std::fs::write(cp.join("ensemble-11.bin.tmp"), [1u8; 10]).unwrap();
        std::fs::write(cp.join("notes.txt"), "kept").unwrap();
        std::fs::write(cp.join("state.json"), "{}").unwrap();
        let again = run_small(Some(&cp), 100, 9);
        assert!(discarded(&again).contains("state.json"));
        let mut names: Vec<String> = std::fs::read_dir(&cp)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "ensemble-0.bin",
                "ensemble-1.bin",
                "ensemble-2.bin",
                "ensemble-3.bin",
                "notes.txt",
                "state.json"
            ]
        );
        assert_files_hold(&cp, &again);
        // And the status serialises as documented.
        assert_eq!(
            serde_json::to_value(&CheckpointStatus::Resumed { steps: 3 }).unwrap(),
            serde_json::json!({"status": "resumed", "steps": 3})
        );
    }
}
