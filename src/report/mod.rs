//! Outputs: CSV tables and figures.

pub mod cmdstan;
pub mod csv;
#[cfg(feature = "figures")]
pub mod figures;
pub mod html;
pub mod json;
pub mod outdir;
pub mod sanity;
