//! Spring: a linear return spring on a mechanical node (single-acting cylinders).
//!
//! # Ports
//! - `rod` — mechanical, force.
//!
//! # Parameters (defaults in brackets)
//! - `stiffness` [N/m, required]: k.
//! - `preload` [N, 0]: spring force at x = 0.
//! - `direction` [`retract`]: the spring pushes towards retract (−) or extend (+).
//!
//! # Equations
//! F = σ·(F₀ + k·x) with σ = −1 for a return spring (Hooke's law). The spring
//! is massless; its mass belongs to the piston's moving mass.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("stiffness", dim::STIFFNESS, None, Range::NonNegative, "N/mm", "spring rate"),
    ParamSpec::quantity("preload", dim::FORCE, Some(0.0), Range::Any, "N", "force at x = 0"),
    ParamSpec::choice("direction", &["retract", "extend"], 0, "direction the spring pushes"),
];
pub const PORTS: &[PortSpec] = &[PortSpec::new("rod", PortKind::MechanicalForce, "spring end on the piston node")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "F", unit: "N" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    pub stiffness: f64,
    pub preload: f64,
    pub sigma: f64,
}

impl Spring {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Spring { stiffness: p.get("stiffness"), preload: p.get("preload"), sigma: if p.choice("direction") == 0 { -1.0 } else { 1.0 } })
    }
    pub fn force(&self, x: f64) -> f64 {
        self.sigma * (self.preload + self.stiffness * x)
    }
}

impl Block for Spring {
    fn type_name(&self) -> &'static str {
        "spring"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn forces(&self, ctx: &Ctx, out: &mut [PortForce]) {
        out[0] = PortForce { applied: self.force(ctx.mechanical[0].x), friction: None };
    }
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Forces {
            d.set(Out::Applied(0), In::X(0), self.sigma * self.stiffness);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.force(ctx.mechanical[0].x));
    }
}

/// Registry entry of `spring`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "spring",
    family: crate::registry::Family::Mechanics,
    doc: "linear return spring",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Spring::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn return_spring_pushes_back_harder_when_compressed() {
        let s = Spring { stiffness: 1000.0, preload: 20.0, sigma: -1.0 };
        assert_eq!(s.force(0.0), -20.0);
        assert_eq!(s.force(0.1), -120.0);
    }
}
