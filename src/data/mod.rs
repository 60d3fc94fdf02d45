//! Measured records: reading, validation, alignment to the release, sanity
//! warnings, and synthetic records for tests and studies.

pub mod ground_motion;
pub mod limits;
pub mod record;
pub mod strict_json;
pub mod synthetic;
pub mod validation;

pub use record::{
    Aligned, Outlier, Record, RecordError, ReleaseSource, MAX_SAMPLES, MIN_SAMPLES,
    OUTLIER_THRESHOLD,
};
pub use synthetic::{random_wide_params, synthesize, Synthetic};
pub use validation::{record_warnings, AccelUnits, UnknownUnits, Warning};
