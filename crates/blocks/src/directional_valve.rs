//! Directional control valves 5/2, 3/2 and 2/2: sets of ISO 6358 paths
//! selected by the spool position, driven by a command signal.
//!
//! ```text
//!  5/2 (types valve_5_2):  rest (u < 0.5): P→B, A→EA     actuated: P→A, B→EB
//!  3/2 (valve_3_2):        normally closed: rest A→E, actuated P→A
//!                          normally open:   rest P→A, actuated A→E
//!  2/2 (valve_2_2):        normally closed: rest shut, actuated a↔b
//!                          normally open:   rest a↔b, actuated shut
//! ```
//!
//! # Ports
//! - pneumatic, flow: 5/2 `P`, `A`, `B`, `EA`, `EB`; 3/2 `P`, `A`, `E`; 2/2 `a`, `b`.
//! - `command` — signal input: 1 actuates the valve, 0 releases it (threshold 0.5).
//!
//! # Parameters (defaults in brackets)
//! - `C` [m³/(s Pa), required], `b` [-, required]: every path (paper Table 2:
//!   490 L/min/bar "all bias"); `m` [0.5], `b_lam` [0.999], `T_ref`, `rho_ref`.
//! - `C_exhaust` [m³/(s Pa), = C], `b_exhaust` [-, = b]: paths to the exhaust
//!   ports (5/2 and 3/2) when they differ from the supply paths.
//! - `normally_open` (3/2 and 2/2) [`no`].
//! - `switching_time` [s, 0]: 0 switches instantly; otherwise the spool
//!   position s follows the command with a first-order lag of time constant
//!   switching_time/3 (95 % of the travel after switching_time), and every
//!   path's flow is scaled by its opening (s or 1 − s).
//!
//! # Equations
//! Each open path is a restriction with ṁ = opening·ṁ_ISO (Eq. 33–35) and
//! energy flow with the upstream enthalpy; the flow at a port is the sum over
//! the paths that touch it.
//!
//! # Assumptions
//! No leakage across closed paths; no overlap/underlap of the spool lands
//! besides the linear opening.

use crate::block::*;
use crate::conductance::characteristic;
use crate::spool_paths::{self, Opening};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

const SWITCHING_TIME: ParamSpec =
    ParamSpec::quantity("switching_time", dim::TIME, Some(0.0), Range::NonNegative, "ms", "spool travel time (0 = instant)");

const EXHAUST_C: ParamSpec = ParamSpec::quantity(
    "C_exhaust",
    dim::CONDUCTANCE,
    Some(0.0),
    Range::NonNegative,
    "L/min/bar",
    "sonic conductance of exhaust paths (default: C)",
);
const EXHAUST_B: ParamSpec = ParamSpec::quantity(
    "b_exhaust",
    dim::DIMENSIONLESS,
    Some(0.0),
    Range::Closed(0.0, 0.999),
    "",
    "critical ratio of exhaust paths (default: b)",
);
const NORMALLY_OPEN: ParamSpec = ParamSpec::choice("normally_open", &["no", "yes"], 0, "valve passes P->A (3/2) or a<->b (2/2) at rest");

pub const PARAMS_5_2: &[ParamSpec] = crate::param_set!(crate::iso6358::PARAMS, &[SWITCHING_TIME, EXHAUST_C, EXHAUST_B]);
pub const PARAMS_3_2: &[ParamSpec] = crate::param_set!(crate::iso6358::PARAMS, &[SWITCHING_TIME, EXHAUST_C, EXHAUST_B, NORMALLY_OPEN]);
pub const PARAMS_2_2: &[ParamSpec] = crate::param_set!(crate::iso6358::PARAMS, &[SWITCHING_TIME, NORMALLY_OPEN]);

pub const PORTS_5_2: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port A (actuated: from P)"),
    PortSpec::new("B", PortKind::PneumaticFlow, "working port B (rest: from P)"),
    PortSpec::new("EA", PortKind::PneumaticFlow, "exhaust of A"),
    PortSpec::new("EB", PortKind::PneumaticFlow, "exhaust of B"),
    PortSpec::signal("command", PortKind::SignalIn, "1", "1 = actuated, 0 = rest"),
];
pub const PORTS_3_2: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port"),
    PortSpec::new("E", PortKind::PneumaticFlow, "exhaust"),
    PortSpec::signal("command", PortKind::SignalIn, "1", "1 = actuated, 0 = rest"),
];
pub const PORTS_2_2: &[PortSpec] = &[
    PortSpec::new("a", PortKind::PneumaticFlow, "side a"),
    PortSpec::new("b", PortKind::PneumaticFlow, "side b"),
    PortSpec::signal("command", PortKind::SignalIn, "1", "1 = actuated, 0 = rest"),
];
const SPOOL_STATE: &[StateSpec] = &[StateSpec { name: "spool", unit: "1" }];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "spool", unit: "1" }];

/// One flow path between two pneumatic ports (indices among pneumatic ports).
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub from: usize,
    pub to: usize,
    pub flow: FlowCharacteristic,
    /// Open when actuated (true) or at rest (false).
    pub when_actuated: bool,
}

/// A directional valve: paths plus spool dynamics.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionalValve {
    pub type_name: &'static str,
    pub ports: &'static [PortSpec],
    pub paths: Vec<Path>,
    /// Lag time constant of the spool [s]; 0 = instant.
    pub spool_tau: f64,
}

impl DirectionalValve {
    fn flows_from_params(p: &Params, with_exhaust: bool) -> Result<(FlowCharacteristic, FlowCharacteristic), crate::BlockError> {
        let supply = characteristic(p, "C", "b")?;
        let exhaust = if with_exhaust && (p.was_given("C_exhaust") || p.was_given("b_exhaust")) {
            let c = if p.was_given("C_exhaust") { p.get("C_exhaust") } else { p.get("C") };
            let b = if p.was_given("b_exhaust") { p.get("b_exhaust") } else { p.get("b") };
            crate::iso6358::with_shared(p, c, b)?
        } else {
            supply
        };
        Ok((supply, exhaust))
    }

    pub fn five_two(p: &Params) -> Result<Self, crate::BlockError> {
        let (s, e) = Self::flows_from_params(p, true)?;
        let path = |from, to, flow, when_actuated| Path { from, to, flow, when_actuated };
        Ok(DirectionalValve {
            type_name: "valve_5_2",
            ports: PORTS_5_2,
            // port indices: P 0, A 1, B 2, EA 3, EB 4
            paths: vec![path(0, 1, s, true), path(2, 4, e, true), path(0, 2, s, false), path(1, 3, e, false)],
            spool_tau: p.get("switching_time") / 3.0,
        })
    }

    pub fn three_two(p: &Params) -> Result<Self, crate::BlockError> {
        let (s, e) = Self::flows_from_params(p, true)?;
        let no = p.choice("normally_open") == 1;
        let path = |from, to, flow, when_actuated| Path { from, to, flow, when_actuated };
        Ok(DirectionalValve {
            type_name: "valve_3_2",
            ports: PORTS_3_2,
            // P 0, A 1, E 2
            paths: vec![path(0, 1, s, !no), path(1, 2, e, no)],
            spool_tau: p.get("switching_time") / 3.0,
        })
    }

    pub fn two_two(p: &Params) -> Result<Self, crate::BlockError> {
        let (s, _) = Self::flows_from_params(p, false)?;
        let no = p.choice("normally_open") == 1;
        Ok(DirectionalValve {
            type_name: "valve_2_2",
            ports: PORTS_2_2,
            paths: vec![Path { from: 0, to: 1, flow: s, when_actuated: !no }],
            spool_tau: p.get("switching_time") / 3.0,
        })
    }

    /// Each path's opening: s when open actuated, 1 − s when open at rest.
    /// A lagged spool moves the openings; a switched one is piecewise constant.
    fn openings(&self, ctx: &Ctx) -> impl Iterator<Item = Opening<'_>> {
        let s = self.spool(ctx);
        let ds = if self.spool_tau > 0.0 && (0.0..=1.0).contains(&ctx.states[0]) { 1.0 } else { 0.0 };
        self.paths.iter().map(move |path| {
            let (opening, slope) = if path.when_actuated { (s, ds) } else { (1.0 - s, -ds) };
            Opening { from: path.from, to: path.to, flow: &path.flow, leak: None, opening, slope }
        })
    }

    /// Spool position in [0, 1] from the states (lag) or the command (instant).
    pub fn spool(&self, ctx: &Ctx) -> f64 {
        if self.spool_tau > 0.0 {
            ctx.states[0].clamp(0.0, 1.0)
        } else if ctx.signals[0] >= 0.5 {
            1.0
        } else {
            0.0
        }
    }
}

impl Block for DirectionalValve {
    fn type_name(&self) -> &'static str {
        self.type_name
    }
    fn ports(&self) -> &[PortSpec] {
        self.ports
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        let command = self.ports.iter().position(|p| p.kind == PortKind::SignalIn).unwrap_or(0);
        vec![(command, Fact::CommandThresholds { released: 0.0, actuated: 1.0 })]
    }
    fn states(&self) -> &[StateSpec] {
        if self.spool_tau > 0.0 {
            SPOOL_STATE
        } else {
            &[]
        }
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        if let Some(s) = out.first_mut() {
            *s = 1.0;
        }
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        spool_paths::flows(self.openings(ctx), ctx, out);
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        Some(spool_paths::port_flow(self.openings(ctx), ctx, port))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        match phase {
            Phase::Flows => spool_paths::flow_partials(self.openings(ctx), ctx, d),
            Phase::Derivatives if self.spool_tau > 0.0 => d.set(Out::Rate(0), In::State(0), -1.0 / self.spool_tau),
            _ => {}
        }
        true
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        if self.spool_tau > 0.0 {
            let target = if ctx.signals[0] >= 0.5 { 1.0 } else { 0.0 };
            out[0] = (target - ctx.states[0]) / self.spool_tau;
        }
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.spool(ctx));
    }
}

/// Registry entry of `valve_5_2`.
pub const TYPE_5_2: crate::registry::BlockType = crate::registry::BlockType {
    name: "valve_5_2",
    family: crate::registry::Family::DirectionalValves,
    doc: "5/2 directional valve",
    params: PARAMS_5_2,
    ports: PORTS_5_2,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(DirectionalValve::five_two(p)),
};

/// Registry entry of `valve_3_2`.
pub const TYPE_3_2: crate::registry::BlockType = crate::registry::BlockType {
    name: "valve_3_2",
    family: crate::registry::Family::DirectionalValves,
    doc: "3/2 directional valve",
    params: PARAMS_3_2,
    ports: PORTS_3_2,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(DirectionalValve::three_two(p)),
};

/// Registry entry of `valve_2_2`.
pub const TYPE_2_2: crate::registry::BlockType = crate::registry::BlockType {
    name: "valve_2_2",
    family: crate::registry::Family::DirectionalValves,
    doc: "2/2 directional valve",
    params: PARAMS_2_2,
    ports: PORTS_2_2,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(DirectionalValve::two_two(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::GasModel;

    fn params(specs: &'static [ParamSpec], extra: &[(&str, RawValue)]) -> Params {
        let mut raw = vec![("C", RawValue::Text("490 L/min/bar".into())), ("b", RawValue::Number(0.3))];
        raw.extend(extra.iter().cloned());
        Params::from_raw(specs, raw.iter().map(|(k, v)| (*k, v))).unwrap()
    }

    #[test]
    fn five_two_routes_supply_to_a_when_actuated_and_to_b_at_rest() {
        let v = DirectionalValve::five_two(&params(PARAMS_5_2, &[])).unwrap();
        let gas = gas::IdealGas::air();
        let sup = gas.state_pt(6e5, 293.0);
        let mid = gas.state_pt(3e5, 293.0);
        let atm = gas.state_pt(1e5, 293.0);
        let nodes = [sup, mid, mid, atm, atm];
        let mut out = [PortFlow::default(); 5];
        for (cmd, filled, vented) in [(1.0, 1, 2), (0.0, 2, 1)] {
            let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &nodes, mechanical: &[], signals: &[cmd] };
            v.flows(&ctx, &mut out);
            assert!(out[filled].mdot < 0.0, "port {filled} should receive air"); // leaves the valve into the node
            assert!(out[vented].mdot > 0.0, "port {vented} should vent");
            let total: f64 = out.iter().map(|f| f.mdot).sum();
            assert!(total.abs() < 1e-15, "mass is conserved inside the valve");
        }
    }

    #[test]
    fn three_two_normally_open_is_inverted() {
        let gas = gas::IdealGas::air();
        let nodes = [gas.state_pt(6e5, 293.0), gas.state_pt(3e5, 293.0), gas.state_pt(1e5, 293.0)];
        let nc = DirectionalValve::three_two(&params(PARAMS_3_2, &[])).unwrap();
        let no = DirectionalValve::three_two(&params(PARAMS_3_2, &[("normally_open", RawValue::Text("yes".into()))])).unwrap();
        let mut a = [PortFlow::default(); 3];
        let mut b = [PortFlow::default(); 3];
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &nodes, mechanical: &[], signals: &[0.0] };
        nc.flows(&ctx, &mut a);
        no.flows(&Ctx { signals: &[1.0], ..ctx }, &mut b);
        assert_eq!(a, b);
        assert_eq!(a[0].mdot, 0.0); // P blocked at rest for normally closed
    }

    #[test]
    fn spool_lag_reaches_95_percent_at_switching_time() {
        let v = DirectionalValve::two_two(&params(PARAMS_2_2, &[("switching_time", RawValue::Text("30 ms".into()))])).unwrap();
        let gas = gas::IdealGas::air();
        let mut s = 0.0;
        let dt = 1e-6;
        let mut out = [0.0];
        for _ in 0..30_000 {
            let ctx = Ctx { t: 0.0, gas: &gas, states: &[s], pneumatic: &[], mechanical: &[], signals: &[1.0] };
            v.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut out);
            s += dt * out[0];
        }
        assert!((s - (1.0 - (-3.0f64).exp())).abs() < 1e-4, "{s}");
    }
}
