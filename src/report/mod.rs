//! Outputs: CSV tables and figures.

pub mod cmdstan;
pub mod csv;
#[cfg(feature = "figures")]
pub mod figures;
pub mod html;
pub mod json;
pub mod outdir;
pub mod verify;

// Its place before it moved beside the residual tests it runs.
pub use crate::criticism::sanity;
