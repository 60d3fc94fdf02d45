//! Outputs: CSV tables and figures.

pub mod csv;
#[cfg(feature = "figures")]
pub mod figures;
pub mod json;
