//! Running a job on rayon's worker threads.
//!
//! The library evaluates a CMA-ES population, the points of a Hessian and
//! the starts of a refit side by side with rayon. Called from a thread
//! outside the pool (a program's main thread), each of those tens of
//! thousands of parallel calls is handed to the pool and waited for
//! through the operating system (a futex wake and sleep, some 10 us);
//! called from a worker, it is split among the workers at once. A front
//! end therefore runs a whole job with [`on_pool`]. On the demo's
//! `record.csv` `hbis diagnose` went from 4.73 to 4.33 s (2 cores) with
//! this alone, and its output is the same to the bit: which thread
//! evaluates a point never changes its value.

/// The stack of a worker thread: a main thread's (8 MiB), since a whole
/// job runs on one ([`on_pool`]).
pub const WORKER_STACK: usize = 8 << 20;

/// Builds rayon's global pool with [`WORKER_STACK`] (the default thread
/// count). Call it before any parallel work; once the pool exists (built
/// here or by a first parallel call) it is left as it is.
pub fn init_pool() {
    // An error means the pool was already built: it is kept.
    let _ = rayon::ThreadPoolBuilder::new()
        .stack_size(WORKER_STACK)
        .build_global();
}

/// Runs `op` on a worker of rayon's global pool and waits for it (at once,
/// on this thread, if it is a worker already). A panic in `op` is raised
/// again here.
///
/// ```
/// let on_worker = hbis::parallel::on_pool(|| rayon::current_thread_index().is_some());
/// assert!(on_worker);
/// ```
pub fn on_pool<R: Send>(op: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| op())
}
