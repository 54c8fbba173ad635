//! End-of-stroke cushioning of a cylinder: over the last part of the
//! stroke a cushion spear closes the main exhaust bore, and the air trapped
//! in the end of the chamber (the cushion volume) can leave only through an
//! adjustable needle restriction; a check valve lets air in freely at the
//! start of the opposite stroke.
//!
//! ```text
//!   chamber ──┬──[ main bore, open outside the cushion ]──┬── line
//!             ├──[ needle C_needle (adjustable) ]─────────┤
//!             └──[ check valve: line → chamber ]──────────┘
//! ```
//!
//! Connect `chamber` to the cylinder chamber's port (`cyl.rod_port` to
//! cushion the extend stroke), `line` to the valve side, and `x` to the
//! piston position. The cushion volume is the part of the cylinder chamber
//! left when the spear enters: A·cushion_length plus the chamber's dead
//! volume.
//!
//! # Ports
//! - `chamber`, `line` — pneumatic, flow.
//! - `x` [m] — signal input: piston position.
//!
//! # Parameters (defaults in brackets)
//! - `end` [`extend`]: the stroke end cushioned: `extend` (arriving at
//!   x = stroke, rod side) or `retract` (arriving at x = 0, head side).
//! - `stroke` [m, required for `extend`]: the cylinder's stroke.
//! - `cushion_length` [m, required, > 0]: length of the cushion spear.
//! - `seal_travel` [m, 1 mm, > 0]: travel over which the cushion seal
//!   closes the main bore (keeps the flow continuous in x).
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: the
//!   main bore.
//! - `C_needle` [m³/(s Pa), required], `b_needle` [-, = b]: the needle
//!   restriction (the adjustment screw).
//! - `C_check` [m³/(s Pa), = C], `b_check` [= b], `cracking_pressure`
//!   [Pa, 0.1 bar], `opening_range` [Pa, 0.1 bar]: the cushion check valve.
//!
//! # Equations
//! With d the distance from the cushioned end (stroke − x, or x), the main
//! bore opens o = clamp((d − (L_c − s))/s, 0, 1) (closed once the spear is
//! in by more than the seal travel s). Flow from chamber to line:
//! ṁ = o·ṁ_ISO,main + ṁ_ISO,needle − ṁ_check(line → chamber), each after
//! paper Eq. 33–35 (the check valve opens as [`crate::check_valve`]).
//! Inside the cushion the trapped air is compressed by the piston and
//! bleeds through the needle, which converts the kinetic energy of the load
//! into heat (the chamber's energy balance, Eq. 13–17).
//!
//! # Assumptions
//! The spear seals tightly (no leakage past the cushion seal besides the
//! needle); the check valve is massless.

use crate::block::*;
use crate::check_valve::OneWay;
use crate::conductance::{add_path, restriction_flow, restriction_partials};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[
        ParamSpec::choice("end", &["extend", "retract"], 0, "stroke end cushioned"),
        ParamSpec::quantity("stroke", dim::LENGTH, Some(0.0), Range::NonNegative, "mm", "cylinder stroke (for end = extend)"),
        ParamSpec::quantity("cushion_length", dim::LENGTH, None, Range::Positive, "mm", "length of the cushion spear"),
        ParamSpec::quantity("seal_travel", dim::LENGTH, Some(1e-3), Range::Positive, "mm", "travel over which the main bore closes"),
    ],
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("C_needle", dim::CONDUCTANCE, None, Range::Positive, "L/min/bar", "needle restriction"),
        ParamSpec::quantity("b_needle", dim::DIMENSIONLESS, Some(0.0), Range::Closed(0.0, 0.999), "", "needle restriction (default: b)"),
        ParamSpec::quantity("C_check", dim::CONDUCTANCE, Some(0.0), Range::NonNegative, "L/min/bar", "cushion check valve (default: C)"),
        ParamSpec::quantity("b_check", dim::DIMENSIONLESS, Some(0.0), Range::Closed(0.0, 0.999), "", "cushion check valve (default: b)"),
        ParamSpec::quantity("cracking_pressure", dim::PRESSURE, Some(0.1e5), Range::NonNegative, "bar", "check valve opening difference"),
        ParamSpec::quantity("opening_range", dim::PRESSURE, Some(0.1e5), Range::Positive, "bar", "check valve: rise to fully open"),
    ]
);
pub const PORTS: &[PortSpec] = &[
    PortSpec::new("chamber", PortKind::PneumaticFlow, "the cylinder chamber's port"),
    PortSpec::new("line", PortKind::PneumaticFlow, "the valve line"),
    PortSpec::signal("x", PortKind::SignalIn, "m", "piston position"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "main_opening", unit: "1" }, OutputSpec { name: "mdot", unit: "kg/s" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Cushion {
    /// Position of the cushioned end [m] and the direction towards it (+1: x rises to it).
    pub end: f64,
    pub towards: f64,
    pub length: f64,
    pub seal: f64,
    pub main: FlowCharacteristic,
    pub needle: FlowCharacteristic,
    pub check: OneWay,
}

impl Cushion {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let extend = p.choice("end") == 0;
        if extend && !p.was_given("stroke") {
            return Err(crate::BlockError::invalid("stroke", "is needed to cushion the extend end (end = extend)"));
        }
        let or_b = |name: &str| if p.was_given(name) { p.get(name) } else { p.get("b") };
        let c_check = if p.was_given("C_check") { p.get("C_check") } else { p.get("C") };
        let c = Cushion {
            end: if extend { p.get("stroke") } else { 0.0 },
            towards: if extend { 1.0 } else { -1.0 },
            length: p.get("cushion_length"),
            seal: p.get("seal_travel"),
            main: crate::iso6358::from_params(p, "C", "b")?,
            needle: crate::iso6358::with_shared(p, p.get("C_needle"), or_b("b_needle"))?,
            check: OneWay {
                flow: crate::iso6358::with_shared(p, c_check, or_b("b_check"))?,
                cracking_pressure: p.get("cracking_pressure"),
                opening_range: p.get("opening_range"),
            },
        };
        if c.seal > c.length {
            return Err(crate::BlockError::invalid("seal_travel", "must not exceed cushion_length"));
        }
        if extend && c.length >= c.end {
            return Err(crate::BlockError::invalid("cushion_length", "must be shorter than the stroke"));
        }
        Ok(c)
    }
    /// Opening of the main bore at piston position x.
    pub fn main_opening(&self, x: f64) -> f64 {
        let d = self.towards * (self.end - x);
        ((d - (self.length - self.seal)) / self.seal).clamp(0.0, 1.0)
    }
    /// Flow into the block at `chamber` (from the chamber to the line).
    fn flow(&self, ctx: &Ctx) -> PortFlow {
        let (ch, line) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
        let mut f = restriction_flow(&self.main, self.main_opening(ctx.signals[0]), ch, line, 0.0);
        f += restriction_flow(&self.needle, 1.0, ch, line, 0.0);
        f += -self.check.flow(line, ch);
        f
    }
}

impl Block for Cushion {
    fn type_name(&self) -> &'static str {
        "cushion"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        let f = self.flow(ctx);
        out[0] = f;
        out[1] = -f;
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Flows {
            let (ch, line) = (&ctx.pneumatic[0], &ctx.pneumatic[1]);
            let x = ctx.signals[0];
            let u = (self.towards * (self.end - x) - (self.length - self.seal)) / self.seal;
            let slope = if u > 0.0 && u < 1.0 { -self.towards / self.seal } else { 0.0 };
            let main = restriction_partials(&self.main, self.main_opening(x), ch, line, 0.0, ctx.gas);
            add_path(d, 0, 1, &main, &[(In::Signal(0), slope)]);
            let needle = restriction_partials(&self.needle, 1.0, ch, line, 0.0, ctx.gas);
            add_path(d, 0, 1, &needle, &[]);
            self.check.add_partials(d, 1, 0, ctx);
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    /// The stroke of the cylinder whose extend end it cushions, on the node of its position input.
    fn facts(&self) -> Vec<(usize, Fact)> {
        if self.towards > 0.0 {
            vec![(2, Fact::Stroke(self.end))]
        } else {
            Vec::new()
        }
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.main_opening(ctx.signals[0]));
        out[1] = Some(self.flow(ctx).mdot);
    }
}

/// Registry entry of `cushion`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "cushion",
    family: crate::registry::Family::Mechanics,
    doc: "end-of-stroke cushioning: spear closes the main bore, needle bleeds",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Cushion::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::GasModel;

    fn cushion() -> Cushion {
        let raw = [
            ("stroke", RawValue::Text("200 mm".into())),
            ("cushion_length", RawValue::Text("20 mm".into())),
            ("C", RawValue::Text("100 L/min/bar".into())),
            ("b", RawValue::Number(0.3)),
            ("C_needle", RawValue::Text("2 L/min/bar".into())),
        ];
        Cushion::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap()
    }

    fn outflow(c: &Cushion, x: f64, p_ch: f64, p_line: f64) -> f64 {
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(p_ch, 293.15), gas.state_pt(p_line, 293.15)];
        let mut out = [PortFlow::default(); 2];
        c.flows(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &n, mechanical: &[], signals: &[x] }, &mut out);
        out[0].mdot
    }

    #[test]
    fn inside_the_cushion_only_the_needle_passes() {
        let c = cushion();
        assert_eq!(c.main_opening(0.1), 1.0);
        assert_eq!(c.main_opening(0.18), 1.0);
        assert!(c.main_opening(0.1805) > 0.0 && c.main_opening(0.1805) < 1.0);
        assert_eq!(c.main_opening(0.19), 0.0);
        // inside: exactly the needle's ISO flow
        let needle = FlowCharacteristic::new(2e-3 / 60.0 / 1e5, 0.3).unwrap().mass_flow(5e5, 293.15, 1e5, 293.15);
        assert!((outflow(&c, 0.19, 5e5, 1e5) - needle).abs() < 1e-15);
        // outside: main bore and needle
        let main = FlowCharacteristic::new(100e-3 / 60.0 / 1e5, 0.3).unwrap().mass_flow(5e5, 293.15, 1e5, 293.15);
        assert!((outflow(&c, 0.1, 5e5, 1e5) - main - needle).abs() < 1e-15);
        // reverse: the check valve lets the line refill the chamber inside the cushion
        assert!(-outflow(&c, 0.19, 1e5, 5e5) > 10.0 * needle);
        // the opening falls monotonically towards the end
        let mut last = 1.0;
        for k in 0..=200 {
            let o = c.main_opening(k as f64 * 1e-3);
            assert!(o <= last);
            last = o;
        }
    }
}
