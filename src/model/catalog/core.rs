//! The paper's spring laws, friction laws and damper as components of the
//! closed-form core (sections 5-6 of the paper; `docs/model.md`).

use crate::model::component::{Core, FeatureKind, ForceComponent, ParamSpec, Slot};
use crate::model::params::ParamName;
use crate::model::spec::{DamperKind, FrictionKind, SpringKind};

/// One law of the closed-form core: a spring law, a friction law or the
/// damper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CoreLaw(pub Core);

impl CoreLaw {
    /// Every core law, in the catalog's order.
    pub const ALL: [CoreLaw; 6] = [
        CoreLaw(Core::Spring(SpringKind::Linear)),
        CoreLaw(Core::Spring(SpringKind::Bilinear)),
        CoreLaw(Core::Spring(SpringKind::Trilinear)),
        CoreLaw(Core::Friction(FrictionKind::Coulomb)),
        CoreLaw(Core::Friction(FrictionKind::Lcfm)),
        CoreLaw(Core::Damper(DamperKind::Viscous)),
    ];

    fn names(self) -> &'static [ParamName] {
        use ParamName::*;
        match self.0 {
            Core::Spring(SpringKind::Linear) => &[F0],
            Core::Spring(SpringKind::Bilinear) => &[Uy, F0, F1],
            Core::Spring(SpringKind::Trilinear) => &[Uy, F0, F1, F2, U3],
            Core::Friction(FrictionKind::None) | Core::Damper(DamperKind::None) => &[],
            Core::Friction(FrictionKind::Coulomb) => &[UF0],
            Core::Friction(FrictionKind::Lcfm) => &[UF0, RF0],
            Core::Damper(DamperKind::Viscous) => &[Zeta0],
        }
    }
}

impl ForceComponent for CoreLaw {
    fn name(&self) -> &str {
        match self.0 {
            Core::Spring(SpringKind::Linear) => "linear",
            Core::Spring(SpringKind::Bilinear) => "bilinear",
            Core::Spring(SpringKind::Trilinear) => "trilinear",
            Core::Friction(FrictionKind::None) | Core::Damper(DamperKind::None) => "none",
            Core::Friction(FrictionKind::Coulomb) => "coulomb",
            Core::Friction(FrictionKind::Lcfm) => "lcfm",
            Core::Damper(DamperKind::Viscous) => "viscous",
        }
    }

    fn params(&self) -> Vec<ParamSpec> {
        self.names().iter().map(|p| p.spec()).collect()
    }

    fn meaning(&self) -> &str {
        match self.0 {
            Core::Spring(SpringKind::Linear) => "a linear rubber-bearing spring, F = k0 u",
            Core::Spring(SpringKind::Bilinear) => {
                "a bi-linear hysteretic rubber-bearing spring (yield at uy)"
            }
            Core::Spring(SpringKind::Trilinear) => {
                "a tri-linear hysteretic rubber-bearing spring (a third branch beyond u3)"
            }
            Core::Friction(FrictionKind::Coulomb) => {
                "a Coulomb slider of constant friction F_F0 = uF0 k0"
            }
            Core::Friction(FrictionKind::Lcfm) => {
                "a linear Coulomb slider whose friction grows with the displacement, F_F0 + k_F |u|"
            }
            Core::Damper(DamperKind::Viscous) => "a linear viscous damper, c = 2 zeta0 w0 m",
            _ => "nothing",
        }
    }

    fn targets(&self) -> Vec<FeatureKind> {
        use FeatureKind::*;
        match self.0 {
            Core::Spring(_) => vec![PeriodAmplitude, PeriodDrift],
            Core::Friction(FrictionKind::None) | Core::Damper(DamperKind::None) => Vec::new(),
            Core::Friction(_) => vec![JumpSize, DecayRate],
            // A damper's force is in phase with velocity; the fit of the
            // friction absorbs most of the decay, and what is left shows
            // as serial correlation over the half-period. Without it the
            // fitted stiffness and friction compensate for the energy lost,
            // which shifts the swings' timing as the amplitude decays: a
            // period drift.
            Core::Damper(_) => vec![DecayRate, Colour, PeriodDrift],
        }
    }

    fn signature(&self) -> &str {
        match self.0 {
            Core::Spring(SpringKind::Trilinear) => "a third stiffness branch beyond u3: the period of the largest swings differs from the smaller ones'",
            Core::Friction(FrictionKind::Lcfm) => "friction growing with amplitude: the acceleration jumps at reversals scale with the amplitude",
            Core::Damper(DamperKind::Viscous) => "viscous damping: residual in phase with velocity, largest mid-swing, amplitude decays faster than friction alone allows",
            Core::Friction(FrictionKind::Coulomb) => "a friction slider: the acceleration jumps at every reversal and the amplitude decays linearly",
            _ => self.meaning(),
        }
    }

    fn core(&self) -> Option<Core> {
        Some(self.0)
    }

    fn upgrades(&self) -> Option<&str> {
        match self.0 {
            Core::Spring(SpringKind::Trilinear) => Some("bilinear"),
            Core::Friction(FrictionKind::Lcfm) => Some("coulomb"),
            _ => None,
        }
    }

    fn requires(&self) -> Option<Slot> {
        // A spring law is never offered as an addition (the slot is
        // always filled); the others fill an empty slot.
        None
    }

    fn piecewise_linear(&self) -> bool {
        true
    }

    /// `f2 = f1` and `u3` between `uy` and `u0` make a tri-linear spring
    /// the bi-linear one it upgrades; everything else starts switched off.
    fn warm_start(&self, current: &dyn Fn(&str) -> Option<f64>) -> Vec<f64> {
        self.names()
            .iter()
            .map(|&p| match p {
                ParamName::F2 => current("f1").unwrap_or(p.spec().neutral),
                ParamName::U3 => match (current("uy"), current("u0")) {
                    (Some(uy), Some(u0)) => 0.5 * (uy + u0),
                    _ => p.spec().neutral,
                },
                _ => p.spec().neutral,
            })
            .collect()
    }
}
