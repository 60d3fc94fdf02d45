//! Small numerical building blocks shared across the crate.

pub mod quadrature;
