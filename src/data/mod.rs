//! Measured records: reading, validation, alignment to the release, and
//! synthetic records for tests and studies.

pub mod record;
pub mod synthetic;

pub use record::{Aligned, Record, RecordError, ReleaseSource, MIN_SAMPLES};
pub use synthetic::{synthesize, Synthetic};
