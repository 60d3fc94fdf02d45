//! Sizes refused before anything is allocated, in the same words from
//! every front end (the binary, the Python package, a library caller).
//!
//! A size a user typed (a duration, a sample count, a number of walkers)
//! must never reach an allocation unchecked: a grid of 1e15 samples or a
//! sampler keeping 7,000 GiB of chains aborts the process (or the Python
//! interpreter) instead of answering.
//!
//! ```
//! use hbis::data::limits;
//!
//! assert!(limits::grid(0.005, 12.0).is_ok());
//! let e = limits::grid(1e-12, 1000.0).unwrap_err();
//! assert!(e.to_string().starts_with("duration 1000 s at dt 0.000000000001 s makes 1.000e15 samples"));
//! let e = limits::sampler(9, 4, 2, 1000).unwrap_err();
//! assert!(e.to_string().contains("at least 2 x 9 = 18 walkers"));
//! ```

use thiserror::Error;

/// Most samples of a simulated grid (`simulate`): 1e7, 14 hours at 200 Hz.
pub const MAX_GRID_SAMPLES: f64 = 1e7;

/// Most memory the chains of a sampler may keep (bytes): 8 GiB.
pub const MAX_CHAIN_BYTES: f64 = 8.0 * 1024.0 * 1024.0 * 1024.0;

/// A size over its limit.
#[derive(Debug, Error, PartialEq)]
pub enum LimitError {
    /// A simulated grid too long to hold.
    #[error("duration {duration} s at dt {dt} s makes {samples:.3e} samples, more than the limit of {MAX_GRID_SAMPLES:.0e}: use a larger dt or a shorter duration")]
    Grid {
        /// Step (s).
        dt: f64,
        /// Duration (s).
        duration: f64,
        /// Samples it would make.
        samples: f64,
    },
    /// Too few walkers for the stretch move.
    #[error("walkers {walkers}: the model has {dim} parameters and the stretch move needs at least 2 x {dim} = {} walkers per ensemble", 2 * dim)]
    Walkers {
        /// Walkers per ensemble.
        walkers: usize,
        /// Parameters.
        dim: usize,
    },
    /// Chains that would not fit in memory.
    #[error("walkers {walkers} x ensembles {ensembles} x max_steps {max_steps} would keep {:.1} GiB of chains in memory, more than the limit of {:.0} GiB: lower one of them", bytes / GIB, MAX_CHAIN_BYTES / GIB)]
    Chains {
        /// Walkers per ensemble.
        walkers: usize,
        /// Ensembles.
        ensembles: usize,
        /// Most steps.
        max_steps: usize,
        /// Bytes the chains would keep.
        bytes: f64,
    },
    /// A pointwise log-likelihood array that would not fit in memory.
    #[error("{draws} draws x {samples} samples would make a {:.1} GiB pointwise log-likelihood, more than the limit of {:.0} GiB: thin the draws (fit's `thin`)", bytes / GIB, MAX_CHAIN_BYTES / GIB)]
    Pointwise {
        /// Kept draws.
        draws: usize,
        /// Samples of the record.
        samples: usize,
        /// Bytes the array would take.
        bytes: f64,
    },
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// Refuses a grid of step `dt` over `duration` with more than
/// [`MAX_GRID_SAMPLES`] samples.
pub fn grid(dt: f64, duration: f64) -> Result<(), LimitError> {
    let samples = duration / dt + 1.0;
    if samples > MAX_GRID_SAMPLES {
        return Err(LimitError::Grid {
            dt,
            duration,
            samples,
        });
    }
    Ok(())
}

/// Refuses, before any work, a sampler the stretch move cannot run (fewer
/// than `2 dim` walkers) or whose chains (positions and log-densities of
/// every step of every walker) would keep more than [`MAX_CHAIN_BYTES`].
pub fn sampler(
    dim: usize,
    walkers: usize,
    ensembles: usize,
    max_steps: usize,
) -> Result<(), LimitError> {
    if walkers < 2 * dim {
        return Err(LimitError::Walkers { walkers, dim });
    }
    let bytes = walkers as f64 * ensembles as f64 * max_steps as f64 * (dim + 1) as f64 * 8.0;
    if bytes > MAX_CHAIN_BYTES {
        return Err(LimitError::Chains {
            walkers,
            ensembles,
            max_steps,
            bytes,
        });
    }
    Ok(())
}

/// Refuses a pointwise log-likelihood (one term per draw and sample) of
/// more than [`MAX_CHAIN_BYTES`].
pub fn pointwise(draws: usize, samples: usize) -> Result<(), LimitError> {
    let bytes = draws as f64 * samples as f64 * 8.0;
    if bytes > MAX_CHAIN_BYTES {
        return Err(LimitError::Pointwise {
            draws,
            samples,
            bytes,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_hold_at_their_edges() {
        assert!(grid(1.0, MAX_GRID_SAMPLES - 1.0).is_ok());
        assert!(grid(1.0, MAX_GRID_SAMPLES).is_err());
        assert!(sampler(9, 18, 1, 1).is_ok());
        assert!(pointwise(1 << 20, 1024).is_ok());
        assert!(pointwise(1 << 20, 1025).is_err());
        assert!(sampler(9, 17, 1, 1).is_err());
        // 8 GiB exactly: 2^30 / (10 * 8) ... one more step goes over.
        let steps = (MAX_CHAIN_BYTES / (20.0 * 10.0 * 8.0)) as usize;
        assert!(sampler(9, 20, 1, steps).is_ok());
        assert!(sampler(9, 20, 1, steps + 1).is_err());
    }
}
