//! Speed-control valve (one-way flow control): a throttle in parallel with a
//! check valve. Free flow from `a` to `b`, throttled flow from `b` to `a`.
//!
//! ```text
//!   a ──┬──[ throttle C, b ]──┬── b
//!       └──[ check a → b   ]──┘
//! ```
//! In a meter-out circuit `b` faces the cylinder: air enters the chamber
//! freely through the check valve and leaves it through the throttle.
//!
//! # Ports
//! - `a`, `b` — pneumatic, flow.
//!
//! # Parameters (defaults in brackets)
//! - `C` [m³/(s Pa), required], `b` [-, required]: throttle (paper Table 1
//!   gives C per switch position, b = 0.3).
//! - `check_C` [m³/(s Pa), required], `check_b` [-, required]: check valve when open.
//! - `cracking_pressure` [Pa, 0], `opening_range` [Pa, 1000 Pa]: check valve opening.
//! - `m` [0.5], `b_lam` [0.999], `T_ref` [293.15 K], `rho_ref` [1.185 kg/m³]:
//!   shared by both paths.
//!
//! # Equations
//! ṁ_a→b = ṁ_ISO,throttle(a, b) + s(p_a − p_b)·ṁ_ISO,check(a → b), each after
//! paper Eq. 33–35; energy flow with the upstream enthalpy.

use crate::block::*;
use crate::check_valve::OneWay;
use crate::conductance::{characteristic, restriction_flow};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[
    ParamSpec::quantity("C", dim::CONDUCTANCE, None, Range::Positive, "L/min/bar", "throttle sonic conductance"),
    ParamSpec::quantity("b", dim::DIMENSIONLESS, None, Range::OpenUnit, "", "throttle critical pressure ratio"),
    ParamSpec::quantity("check_C", dim::CONDUCTANCE, None, Range::Positive, "L/min/bar", "check valve sonic conductance"),
    ParamSpec::quantity("check_b", dim::DIMENSIONLESS, None, Range::OpenUnit, "", "check valve critical pressure ratio"),
    ParamSpec::quantity(
        "cracking_pressure",
        dim::PRESSURE,
        Some(0.0),
        Range::NonNegative,
        "bar",
        "check valve opening pressure difference",
    ),
    ParamSpec::quantity("opening_range", dim::PRESSURE, Some(1000.0), Range::Positive, "bar", "check valve: pressure rise to fully open"),
    ],
    crate::iso6358::SHARED
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("a", PortKind::PneumaticFlow, "free-flow inlet (valve side in meter-out)"),
    PortSpec::new("b", PortKind::PneumaticFlow, "free-flow outlet (cylinder side in meter-out)"),
];
pub const OUTPUTS: &[OutputSpec] = &[
    OutputSpec { name: "mdot", unit: "kg/s" },
    OutputSpec { name: "mdot_throttle", unit: "kg/s" },
    OutputSpec { name: "mdot_check", unit: "kg/s" },
];

#[derive(Debug, Clone, PartialEq)]
pub struct SpeedControlValve {
    pub throttle: FlowCharacteristic,
    pub check: OneWay,
}

impl SpeedControlValve {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(SpeedControlValve {
            throttle: characteristic(p, "C", "b")?,
            check: OneWay {
                flow: characteristic(p, "check_C", "check_b")?,
                cracking_pressure: p.get("cracking_pressure"),
                opening_range: p.get("opening_range"),
            },
        })
    }
    fn paths(&self, a: &gas::GasState, b: &gas::GasState) -> (PortFlow, PortFlow) {
        (restriction_flow(&self.throttle, 1.0, a, b, 0.0), self.check.flow(a, b))
    }
}

impl Block for SpeedControlValve {
    fn type_name(&self) -> &'static str {
        "speed_control_valve"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let (mut f, check) = self.paths(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        f += check;
        out[0] = f;
        out[1] = -f;
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        let (a, b) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let (mut f, mut da, mut db) = crate::conductance::restriction_flow_slopes(&self.throttle, 1.0, a, b, 0.0);
        let (fc, dca, dcb) = self.check.flow_slopes(a, b);
        f += fc;
        da += dca;
        db += dcb;
        Some(crate::conductance::at_port(port, f, da, db))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            let (a, b) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
            let r = crate::conductance::restriction_partials(&self.throttle, 1.0, a, b, 0.0, ctx.gas);
            crate::conductance::add_path(d, 0, 1, &r, &[]);
            self.check.add_partials(d, 0, 1, ctx);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let (t, c) = self.paths(&ctx.pneumatic[0], &ctx.pneumatic[1]);
        out[0] = Some(t.mdot + c.mdot);
        out[1] = Some(t.mdot);
        out[2] = Some(c.mdot);
    }
}

/// Registry entry of `speed_control_valve`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "speed_control_valve",
    family: crate::registry::Family::Restrictions,
    doc: "throttle in parallel with a check valve",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(SpeedControlValve::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use gas::GasModel;

    #[test]
    fn free_one_way_throttled_the_other() {
        let lmin_bar = 1e-3 / 60.0 / 1e5;
        let v = SpeedControlValve {
            throttle: FlowCharacteristic::new(13.2 * lmin_bar, 0.3).unwrap(),
            check: OneWay { flow: FlowCharacteristic::new(490.0 * lmin_bar, 0.3).unwrap(), cracking_pressure: 0.0, opening_range: 1000.0 },
        };
        let gas = gas::IdealGas::air();
        let hi = gas.state_pt(4e5, 292.0);
        let lo = gas.state_pt(2e5, 292.0);
        let (t, c) = v.paths(&hi, &lo);
        let forward = t.mdot + c.mdot;
        let (t2, c2) = v.paths(&lo, &hi);
        let backward = -(t2.mdot + c2.mdot);
        assert_eq!(c2.mdot, 0.0);
        // forward passes both paths: (13.2 + 490)/13.2 times the throttled flow
        assert!((forward / backward - (13.2 + 490.0) / 13.2).abs() < 1e-9, "{}", forward / backward);
    }
}

#[cfg(test)]
pub(crate) mod slope_tests {
    use crate::block::{Block, Ctx, PortFlow};
    use gas::{GasModel, GasState};

    /// Checks `port_flow` of a multi-port block against `flows` and a central
    /// difference of `flows` in each port's pressure, at the given states,
    /// signals and port gas states.
    pub(crate) fn check_port_flow_slopes(b: &dyn Block, states: &[f64], signals: &[f64], nodes: &[GasState]) {
        let gas = gas::IdealGas::air();
        let n = nodes.len();
        let flows_at = |st: &[GasState]| {
            let ctx = Ctx { t: 0.0, gas: &gas, states, pneumatic: st, mechanical: &[], signals };
            let mut o = vec![PortFlow::default(); n];
            b.flows(&ctx, &mut o);
            o
        };
        let out = flows_at(nodes);
        for port in 0..n {
            let ctx = Ctx { t: 0.0, gas: &gas, states, pneumatic: nodes, mechanical: &[], signals };
            let (f, slope) = b.port_flow(&ctx, port).expect("the block gives its slope");
            let tol = 1e-12 * out[port].mdot.abs().max(1e-12);
            assert!((f.mdot - out[port].mdot).abs() <= tol, "{}: port {port} flow {} vs {}", b.type_name(), f.mdot, out[port].mdot);
            let fd = |dp: f64| {
                let mut st = nodes.to_vec();
                let t = st[port].t;
                st[port] = gas.state_pt(st[port].p + dp, t);
                flows_at(&st)[port].mdot
            };
            let h = 1e-3;
            let numeric = (fd(h) - fd(-h)) / (2.0 * h);
            let scale = numeric.abs().max(slope.abs()).max(1e-15);
            assert!((numeric - slope).abs() <= 1e-4 * scale, "{} port {port}: slope {slope} vs {numeric}", b.type_name());
        }
    }

    /// `port_flow` of every two-port restriction agrees with `flows` and with a
    /// central difference of `flows` in the port's pressure, on both sides of
    /// the check valve's opening range, subsonic and choked.
    #[test]
    fn port_flow_slopes_match_finite_differences() {
        let gas = gas::IdealGas::air();
        let blocks: Vec<(&str, Vec<(&str, crate::params::RawValue)>)> = vec![
            (
                "conductance",
                vec![("C", crate::params::RawValue::Text("13.2 L/min/bar".into())), ("b", crate::params::RawValue::Number(0.3))],
            ),
            (
                "check_valve",
                vec![("C", crate::params::RawValue::Text("100 L/min/bar".into())), ("b", crate::params::RawValue::Number(0.3))],
            ),
            (
                "speed_control_valve",
                vec![
                    ("C", crate::params::RawValue::Text("13.2 L/min/bar".into())),
                    ("b", crate::params::RawValue::Number(0.3)),
                    ("check_C", crate::params::RawValue::Text("490 L/min/bar".into())),
                    ("check_b", crate::params::RawValue::Number(0.3)),
                ],
            ),
        ];
        for (kind, params) in &blocks {
            let b = crate::registry::build(kind, params.iter().map(|(k, v)| (*k, v))).unwrap();
            for (pa, pb) in [(4e5, 1e5), (4e5, 3.9e5), (4e5, 3.9995e5), (3.9995e5, 4e5), (1e5, 4e5), (2e5, 1.999e5)] {
                for port in 0..2 {
                    let states = [gas.state_pt(pa, 300.0), gas.state_pt(pb, 280.0)];
                    let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &states, mechanical: &[], signals: &[] };
                    let mut out = [PortFlow::default(); 2];
                    b.flows(&ctx, &mut out);
                    let (f, slope) = b.port_flow(&ctx, port).expect("restrictions give their slope");
                    assert!((f.mdot - out[port].mdot).abs() <= 1e-12 * out[port].mdot.abs().max(1e-12), "{kind}: flow");
                    let fd = |dp: f64| {
                        let mut st = states;
                        let t = st[port].t;
                        st[port] = gas.state_pt(st[port].p + dp, t);
                        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &st, mechanical: &[], signals: &[] };
                        let mut o = [PortFlow::default(); 2];
                        b.flows(&ctx, &mut o);
                        o[port].mdot
                    };
                    let h = 1e-3;
                    let numeric = (fd(h) - fd(-h)) / (2.0 * h);
                    let scale = numeric.abs().max(slope.abs()).max(1e-15);
                    assert!((numeric - slope).abs() <= 1e-4 * scale, "{kind} pa {pa} pb {pb} port {port}: slope {slope} vs {numeric}");
                }
            }
        }
    }
}
