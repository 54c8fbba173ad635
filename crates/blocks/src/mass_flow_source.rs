//! Mass-flow source: pushes a prescribed mass flow into a node.
//!
//! # Ports
//! - `port` — pneumatic, flow.
//!
//! # Parameters
//! - `mdot` [kg/s, required]: mass flow delivered into the node (negative
//!   draws gas out).
//! - `T` [K, 293.15 K]: temperature of the delivered gas.
//!
//! `mdot` and `T` are live: an interface input may drive them (piecewise constant).
//!
//! # Equations
//! Delivered gas carries h(p_node, T); drawn gas carries the node's h
//! (upstream enthalpy, as in Eq. 9/10). The delivered mass is integrated and
//! reported as free air consumption (ANR litres, ISO 8778), as for a supply.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("mdot", dim::MASS_FLOW, None, Range::Any, "g/s", "mass flow into the node"),
    ParamSpec::quantity("T", dim::TEMPERATURE, Some(293.15), Range::GasTemperature, "K", "temperature of the delivered gas"),
];
pub const PORTS: &[PortSpec] = &[PortSpec::new("port", PortKind::PneumaticFlow, "delivered flow")];

#[derive(Debug, Clone, PartialEq)]
pub struct MassFlowSource {
    pub mdot: f64,
    pub t: f64,
}

impl MassFlowSource {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(MassFlowSource { mdot: p.get("mdot"), t: p.get("T") })
    }
}

impl Block for MassFlowSource {
    fn type_name(&self) -> &'static str {
        "mass_flow_source"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Boundary
    }
    fn quadratures(&self) -> &[OutputSpec] {
        crate::pressure_source::DELIVERED
    }
    fn quadrature_rates(&self, _ctx: &Ctx, balances: &Balances, _derivs: &[f64], out: &mut [f64]) {
        out[0] = -balances.pneumatic[0].mdot;
    }
    fn quadrature_statistics(&self, increments: &[f64]) -> Vec<(&'static str, Option<f64>)> {
        crate::pressure_source::free_air(increments)
    }
    /// A flow an interface input drives.
    fn live_parameters(&self) -> &'static [&'static str] {
        &["mdot", "T"]
    }
    fn set_live_parameter(&mut self, name: &str, value: f64) {
        match name {
            "mdot" => self.mdot = value,
            "T" => self.t = value,
            _ => {}
        }
    }
    /// ∂/∂mdot of ṁ = −mdot and Ė = −mdot·h (h of the branch `flows`
    /// takes; at mdot = 0 the delivering side), and ∂Ė/∂T = −mdot·∂h/∂T at
    /// the node's pressure while delivering (drawn gas carries the node's h).
    fn live_partials(&self, name: &str, phase: Phase, ctx: &Ctx, out: &mut [f64]) -> bool {
        if name != "mdot" && name != "T" {
            return false;
        }
        if phase == Phase::Flows {
            let node = ctx.pneumatic[0];
            let delivered = ctx.gas.state_pt(node.p, self.t);
            let h = if self.mdot >= 0.0 { delivered.h } else { node.h };
            if name == "mdot" {
                out[0] = -1.0;
                out[1] = -h;
            } else if self.mdot > 0.0 {
                out[1] = -self.mdot * crate::support::GasSlopes::at(ctx.gas, &delivered).dh_dt;
            }
        }
        true
    }
    /// Exact when the source is shut (a plug: no mass, no energy, whatever
    /// the node does); with a flow the enthalpy's gas-law derivatives are
    /// left to `solve`'s differences (false).
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        phase != Phase::Flows || self.mdot == 0.0
    }
    fn quadrature_partials(&self, _ctx: &Ctx, _b: &Balances, _derivs: &[f64], d: &mut Partials) -> bool {
        d.set(Out::Quadrature(0), In::Mdot(0), -1.0);
        true
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let node = ctx.pneumatic[0];
        let h = if self.mdot >= 0.0 { ctx.gas.enthalpy(ctx.gas.density(node.p, self.t), self.t) } else { node.h };
        // flows are positive INTO this block; it delivers mdot to the node
        out[0] = PortFlow { mdot: -self.mdot, edot: -self.mdot * h };
    }
}

/// Registry entry of `mass_flow_source`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "mass_flow_source",
    family: crate::registry::Family::Sources,
    doc: "prescribed mass flow into a node",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(MassFlowSource::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn delivers_its_enthalpy_and_draws_the_node_enthalpy() {
        let gas = gas::IdealGas::air();
        let node = gas.state_pt(2e5, 280.0);
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[node], mechanical: &[], signals: &[] };
        let mut out = [PortFlow::default()];
        MassFlowSource { mdot: 1e-3, t: 350.0 }.flows(&ctx, &mut out);
        assert_eq!(out[0].mdot, -1e-3);
        assert!((out[0].edot + 1e-3 * gas.enthalpy(1.0, 350.0)).abs() < 1e-9);
        MassFlowSource { mdot: -1e-3, t: 350.0 }.flows(&ctx, &mut out);
        assert!((out[0].edot - 1e-3 * node.h).abs() < 1e-9);
    }
}
