//! Small numerical building blocks shared across the crate.

pub mod affine;
pub mod ode;
pub mod quadrature;
