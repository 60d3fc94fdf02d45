//! Cancelling a run from another thread.
//!
//! A front end that gives up on a run (Python's Ctrl-C, a closed notebook
//! cell) holds a [`Cancel`] and calls [`Cancel::cancel`]; the run's long
//! loops (each CMA-ES generation, each predicted draw) check it and end
//! with [`Cancelled`], so an abandoned run stops computing instead of
//! finishing unseen. A run given no token is never cancelled.
//!
//! ```
//! use hbis::cancel::Cancel;
//!
//! let token = Cancel::new();
//! let seen_by_run = token.clone();
//! assert!(seen_by_run.check().is_ok());
//! token.cancel();
//! assert!(seen_by_run.is_cancelled());
//! assert_eq!(seen_by_run.check().unwrap_err().to_string(), "the run was cancelled");
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use thiserror::Error;

/// The error of a run that was cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("the run was cancelled")]
pub struct Cancelled;

/// A shared flag: clones see the same cancellation.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not (yet) cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every run holding a clone of this token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether [`Cancel::cancel`] was called on this token or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// `Err(Cancelled)` once the token is cancelled.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// Tokens are equal when they are clones of one another (settings that
/// hold one stay comparable).
impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}
