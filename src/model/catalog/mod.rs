//! The catalog: every built-in component, one file each.
//!
//! | component | kind | parameters | engine |
//! |---|---|---|---|
//! | `linear`, `bilinear`, `trilinear` | spring law | `f0`; `uy, f0, f1`; `uy, f0, f1, f2, u3` | closed form |
//! | `coulomb`, `lcfm` | friction law | `uF0`; `uF0, rF0` | closed form |
//! | `viscous` | damper | `zeta0` | closed form |
//! | `asymmetric-friction` | force | `a_F` | closed form |
//! | `velocity-friction` | force | `r_mu`, `v_t` | numerical |
//! | `friction-decay` | force | `kappa_F` | numerical |
//! | `degradation` | force | `kappa_k` | numerical |
//! | `maxwell` | force with memory (`q_m`) | `r_m`, `tau_m` | numerical |
//! | `bouc-wen` | spring law with memory (`z_bw`) | `f0` (core); `f2, uy, n, beta` | numerical |
//! | `offset` | output | `a_off` | (output) |
//! | `averaging` | sensor (the mean over each sample interval) | none | (output; offered on request) |
//!
//! The release displacement `u0` belongs to the model itself: every model
//! is released from it.

mod asymmetric_friction;
pub mod averaging;
mod bouc_wen;
mod core;
mod degradation;
mod friction_decay;
mod maxwell;
mod offset;
mod velocity_friction;

pub use asymmetric_friction::AsymmetricFriction;
pub use averaging::Averaging;
pub use bouc_wen::BoucWen;
pub use core::CoreLaw;
pub use degradation::Degradation;
pub use friction_decay::FrictionDecay;
pub use maxwell::Maxwell;
pub use offset::Offset;
pub use velocity_friction::VelocityFriction;
