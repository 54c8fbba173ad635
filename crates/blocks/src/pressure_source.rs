//! Pressure source: a reservoir of fixed pressure and temperature (supply, or
//! the atmosphere/exhaust).
//!
//! # Ports
//! - `port` — pneumatic, effort: imposes p and T.
//!
//! # Parameters
//! - type `pressure_source`: `p` [Pa, required], `T` [K, 293.15 K].
//! - type `atmosphere`: `p` [Pa, 101 325 Pa], `T` [K, 293.15 K].
//!
//! `p` and `T` are live: an interface input may drive them (piecewise
//! constant, e.g. a supply pressure changed between communication steps).
//!
//! # Equations
//! The port state is (p, T, ρ(p, T), h(ρ, T)) from the circuit's gas model.
//! Gas flowing out of the source carries that enthalpy; gas flowing in
//! disappears (infinite capacity). A supply (`pressure_source`) integrates
//! the mass it delivers: the run's summary reports it as free air
//! consumption, V = m/ρ_ANR in ANR litres (ISO 8778 reference atmosphere,
//! ρ_ANR = 1.185 kg/m³), per cycle and per minute. The paper assumes constant supply and
//! ambient conditions (§2.1); a finite supply line is composed from a
//! conductance and a chamber.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use gas::GasState;
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("p", dim::PRESSURE, None, Range::AbsolutePressure, "bar", "absolute pressure"),
    ParamSpec::quantity("T", dim::TEMPERATURE, Some(293.15), Range::GasTemperature, "K", "temperature"),
];
pub const ATMOSPHERE_PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("p", dim::PRESSURE, Some(101_325.0), Range::AbsolutePressure, "bar", "ambient pressure"),
    ParamSpec::quantity("T", dim::TEMPERATURE, Some(293.15), Range::GasTemperature, "K", "ambient temperature"),
];
pub const PORTS: &[PortSpec] = &[PortSpec::new("port", PortKind::PneumaticEffort, "gas at the source state")];

/// The quadrature of a supply: the mass it delivered.
pub const DELIVERED: &[OutputSpec] = &[OutputSpec { name: "delivered", unit: "kg" }];

/// Free air [m³ ANR] of a delivered mass: V = m/ρ_ANR with the ISO 8778
/// standard reference atmosphere (20 °C, 100 kPa, 65 % relative humidity,
/// ρ = 1.185 kg/m³, the ANR reference of ISO 6358) — the volume compressors
/// are sized in.
pub fn free_air(increments: &[f64]) -> Vec<(&'static str, Option<f64>)> {
    vec![("free_air", increments.first().map(|m| m / crate::iso6358::ANR_DENSITY))]
}

#[derive(Debug, Clone, PartialEq)]
pub struct PressureSource {
    pub p: f64,
    pub t: f64,
    pub name: &'static str,
}

impl PressureSource {
    pub fn from_params(params: &Params, name: &'static str) -> Result<Self, crate::BlockError> {
        Ok(PressureSource { p: params.get("p"), t: params.get("T"), name })
    }
}

impl Block for PressureSource {
    fn type_name(&self) -> &'static str {
        self.name
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Boundary
    }
    fn effort(&self, ctx: &Ctx, out: &mut [GasState]) {
        out[0] = ctx.gas.state_pt(self.p, self.t);
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(0, if self.name == "atmosphere" { Fact::AmbientPressure(self.p) } else { Fact::SupplyPressure(self.p) })]
    }
    /// A supply whose pressure or temperature an interface input drives.
    fn live_parameters(&self) -> &'static [&'static str] {
        &["p", "T"]
    }
    fn set_live_parameter(&mut self, name: &str, value: f64) {
        match name {
            "p" => self.p = value,
            "T" => self.t = value,
            _ => {}
        }
    }
    /// The port's p and T are the parameters (density and enthalpy follow
    /// through the gas model, as for any effort): unit partials.
    fn live_partials(&self, name: &str, phase: Phase, _ctx: &Ctx, out: &mut [f64]) -> bool {
        let row = match name {
            "p" => 0,
            "T" => 1,
            _ => return false,
        };
        if phase == Phase::Effort {
            out[row] = 1.0;
        }
        true
    }
    /// A supply integrates the mass it delivers (for its air consumption); an atmosphere does not.
    fn quadratures(&self) -> &[OutputSpec] {
        if self.name == "atmosphere" {
            &[]
        } else {
            DELIVERED
        }
    }
    fn quadrature_rates(&self, _ctx: &Ctx, balances: &Balances, _derivs: &[f64], out: &mut [f64]) {
        // the net flow the circuit draws from the node is what the source delivers
        out[0] = -balances.pneumatic[0].mdot;
    }
    fn quadrature_partials(&self, _ctx: &Ctx, _b: &Balances, _derivs: &[f64], d: &mut Partials) -> bool {
        d.set(Out::Quadrature(0), In::Mdot(0), -1.0);
        true
    }
    fn quadrature_statistics(&self, increments: &[f64]) -> Vec<(&'static str, Option<f64>)> {
        free_air(increments)
    }
}

/// Registry entry of `pressure_source`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "pressure_source",
    family: crate::registry::Family::Sources,
    doc: "reservoir at fixed p and T (supply); reports the free air it delivers",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(PressureSource::from_params(p, "pressure_source")),
};

/// Registry entry of `atmosphere`.
pub const ATMOSPHERE: crate::registry::BlockType = crate::registry::BlockType {
    name: "atmosphere",
    family: crate::registry::Family::Sources,
    doc: "ambient reservoir (exhaust)",
    params: ATMOSPHERE_PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(PressureSource::from_params(p, "atmosphere")),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn publishes_its_state() {
        let gas = gas::IdealGas::air();
        let s = PressureSource { p: 4e5, t: 292.0, name: "pressure_source" };
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &[] };
        let mut out = [GasState { p: 0.0, t: 0.0, rho: 0.0, h: 0.0 }];
        s.effort(&ctx, &mut out);
        assert_eq!(out[0].p, 4e5);
        assert!((out[0].rho - 4e5 / (287.05 * 292.0)).abs() < 1e-12);
        assert!((out[0].h - gas.enthalpy(out[0].rho, 292.0)).abs() < 1e-9);
    }
}
