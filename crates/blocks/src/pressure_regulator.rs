//! Pressure regulator (pressure-reducing valve), relieving or
//! non-relieving, with the flow–droop characteristic of ISO 6953-1.
//!
//! ```text
//!   P ──[ supply poppet, opening x ]──┬── A (regulated outlet)
//!                                     └──[ relief seat, opening y ]── E  (relieving only)
//! ```
//!
//! # Ports
//! - `P` (supply), `A` (outlet) — pneumatic, flow; `E` (exhaust) — only for
//!   a relieving regulator.
//!
//! # Parameters (defaults in brackets)
//! - `p_set` [Pa, required]: outlet set pressure (absolute; write "4 barg"
//!   for a gauge setting): the outlet pressure at zero flow.
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: the
//!   supply passage fully open.
//! - `droop` [Pa, 0.2 bar, > 0]: fall of the outlet pressure from `p_set`
//!   at which the supply passage is fully open — the proportional band of
//!   the regulator, which sets the slope of its flow characteristic.
//! - `relieving` [`yes`]: `yes` — outlet pressure above the set pressure
//!   vents through E; `no` — it is held (non-relieving, no port E).
//! - `C_relief`, `b_relief` [= C, b]: the relief passage fully open;
//!   `relief_offset` [Pa, 0.05 bar]: outlet pressure above `p_set` at which
//!   relief starts (a dead band, so that supply and relief never open
//!   together).
//! - `response_time` [s, 0]: first-order lag τ of both openings (the
//!   diaphragm and poppet); 0 = they follow the outlet pressure at once.
//!
//! # Equations
//! Force balance of a balanced poppet against its set spring, linearised:
//! x = clamp((p_set − p_A)/Δp_droop, 0, 1),
//! y = clamp((p_A − p_set − Δp_offset)/Δp_droop, 0, 1);
//! ṁ_P→A = x·ṁ_ISO(p_P, p_A), ṁ_A→E = y·ṁ_ISO,relief(p_A, p_E) (paper
//! Eq. 33–35). In steady state at outlet flow ṁ with a choked supply
//! passage this gives the ISO 6953-1 flow characteristic
//! p_A = p_set − Δp_droop·ṁ/(C·ρ_ref·K_T·p_P): the outlet pressure falls
//! linearly with the flow, by Δp_droop at the full-open flow.
//! With `response_time` τ > 0 the openings are states: τ·ẋ = x_target − x.
//!
//! # Assumptions
//! Balanced poppet: the supply pressure does not move the set point (the
//! ISO 6953 "regulation characteristic" is flat); no hysteresis of the
//! diaphragm; no leakage. The set pressure must lie below the supply
//! (checked against the sources upstream when the circuit is built).

use crate::block::*;
use crate::conductance::restriction_flow;
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use crate::support::ramp;
use units::dim;

/// Parameters shared with the proportional pressure valve (all but `p_set`).
pub const REGULATOR: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("droop", dim::PRESSURE, Some(0.2e5), Range::Positive, "bar", "outlet pressure fall to full opening"),
        ParamSpec::choice("relieving", &["yes", "no"], 0, "outlet overpressure vents through E"),
        ParamSpec::quantity("C_relief", dim::CONDUCTANCE, Some(0.0), Range::NonNegative, "L/min/bar", "relief passage (default: C)"),
        ParamSpec::quantity("b_relief", dim::DIMENSIONLESS, Some(0.0), Range::Closed(0.0, 0.999), "", "relief passage (default: b)"),
        ParamSpec::quantity("relief_offset", dim::PRESSURE, Some(0.05e5), Range::NonNegative, "bar", "relief starts this far above p_set"),
        ParamSpec::quantity("response_time", dim::TIME, Some(0.0), Range::NonNegative, "ms", "lag of the openings (0 = instant)"),
    ]
);

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[ParamSpec::quantity("p_set", dim::PRESSURE, None, Range::AbsolutePressure, "bar", "outlet set pressure (absolute)")],
    REGULATOR
);

pub const PORTS_RELIEVING: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "regulated outlet"),
    PortSpec::new("E", PortKind::PneumaticFlow, "relief exhaust (relieving only)"),
];
pub const PORTS_NON_RELIEVING: &[PortSpec] =
    &[PortSpec::new("P", PortKind::PneumaticFlow, "supply"), PortSpec::new("A", PortKind::PneumaticFlow, "regulated outlet")];
const STATES: &[StateSpec] = &[StateSpec { name: "x_supply", unit: "1" }, StateSpec { name: "x_relief", unit: "1" }];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "x_supply", unit: "1" }, OutputSpec { name: "x_relief", unit: "1" }];

/// The passages of a regulator and their opening laws (used by the
/// regulator and the proportional pressure valve).
#[derive(Debug, Clone, PartialEq)]
pub struct Regulation {
    pub supply: FlowCharacteristic,
    /// Relief passage (None: non-relieving).
    pub relief: Option<FlowCharacteristic>,
    pub droop: f64,
    pub relief_offset: f64,
    /// Lag τ of the openings [s]; 0 = algebraic.
    pub tau: f64,
}

impl Regulation {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let supply = crate::iso6358::from_params(p, "C", "b")?;
        let relief = if p.choice("relieving") == 0 {
            let c = if p.was_given("C_relief") { p.get("C_relief") } else { p.get("C") };
            let b = if p.was_given("b_relief") { p.get("b_relief") } else { p.get("b") };
            Some(crate::iso6358::with_shared(p, c, b)?)
        } else {
            if p.was_given("C_relief") || p.was_given("b_relief") {
                return Err(crate::BlockError::invalid("C_relief", "a non-relieving regulator has no relief passage"));
            }
            None
        };
        Ok(Regulation { supply, relief, droop: p.get("droop"), relief_offset: p.get("relief_offset"), tau: p.get("response_time") })
    }
    /// Target openings (supply, relief) at outlet pressure p_a for set pressure p_set.
    pub fn targets(&self, p_set: f64, p_a: f64) -> (f64, f64) {
        let x = ramp(p_set - p_a, 0.0, self.droop);
        let y = if self.relief.is_some() { ramp(p_a - p_set - self.relief_offset, 0.0, self.droop) } else { 0.0 };
        (x, y)
    }
    /// Openings in use: the targets, or the lagged states.
    pub fn openings(&self, p_set: f64, p_a: f64, states: &[f64]) -> (f64, f64) {
        if self.tau > 0.0 && states.len() >= 2 {
            (states[0].clamp(0.0, 1.0), states[1].clamp(0.0, 1.0))
        } else {
            self.targets(p_set, p_a)
        }
    }
    /// Flows into the block at P, A (and E) for set pressure p_set.
    pub fn flows(&self, p_set: f64, ctx: &Ctx, states: &[f64], out: &mut [PortFlow]) {
        let (x, y) = self.openings(p_set, ctx.pneumatic[1].p, states);
        out.fill(PortFlow::default());
        let f = restriction_flow(&self.supply, x, &ctx.pneumatic[0], &ctx.pneumatic[1], 0.0);
        out[0] += f;
        out[1] += -f;
        if let (Some(relief), Some(e)) = (&self.relief, ctx.pneumatic.get(2)) {
            let r = restriction_flow(relief, y, &ctx.pneumatic[1], e, 0.0);
            out[1] += r;
            out[2] += -r;
        }
    }
    /// Partials of the flows or the lag derivatives (by `phase`) for a set
    /// pressure that moves with the block's inputs as `dp_set` lists; the
    /// lagged openings are the block's states `first` and `first + 1`.
    pub fn partials(&self, phase: Phase, p_set: f64, dp_set: &[(In, f64)], first: usize, ctx: &Ctx, d: &mut Partials) {
        let p_a = ctx.pneumatic[1].p;
        // targets: x = ramp(p_set − p_a), y = ramp(p_a − p_set − offset)
        let sx = crate::support::ramp_slope(p_set - p_a, 0.0, self.droop);
        let sy = if self.relief.is_some() { crate::support::ramp_slope(p_a - p_set - self.relief_offset, 0.0, self.droop) } else { 0.0 };
        let target = |slope: f64, sign: f64| -> Vec<(In, f64)> {
            let mut v: Vec<(In, f64)> = dp_set.iter().map(|&(i, x)| (i, sign * slope * x)).collect();
            v.push((In::P(1), -sign * slope));
            v
        };
        let (tx, ty) = (target(sx, 1.0), target(sy, -1.0));
        let states = ctx.states.get(first..).unwrap_or(&[]);
        let lagged = self.tau > 0.0 && states.len() >= 2;
        match phase {
            Phase::Flows => {
                let (x, y) = self.openings(p_set, p_a, states);
                let inside = |v: f64| (0.0..=1.0).contains(&v);
                let (dx, dy) = if lagged {
                    let own = |k: usize| if inside(states[k]) { vec![(In::State(first + k), 1.0)] } else { Vec::new() };
                    (own(0), own(1))
                } else {
                    (tx, ty)
                };
                let r = crate::conductance::restriction_partials(&self.supply, x, &ctx.pneumatic[0], &ctx.pneumatic[1], 0.0, ctx.gas);
                crate::conductance::add_path(d, 0, 1, &r, &dx);
                if let (Some(relief), Some(e)) = (&self.relief, ctx.pneumatic.get(2)) {
                    let r = crate::conductance::restriction_partials(relief, y, &ctx.pneumatic[1], e, 0.0, ctx.gas);
                    crate::conductance::add_path(d, 1, 2, &r, &dy);
                }
            }
            Phase::Derivatives if lagged => {
                for (k, t) in [(first, tx), (first + 1, ty)] {
                    d.set(Out::Rate(k), In::State(k), -1.0 / self.tau);
                    for (i, v) in t {
                        d.add(Out::Rate(k), i, v / self.tau);
                    }
                }
            }
            _ => {}
        }
    }
    /// Lag derivatives of the two openings.
    pub fn derivatives(&self, p_set: f64, p_a: f64, states: &[f64], out: &mut [f64]) {
        if self.tau > 0.0 && states.len() >= 2 && out.len() >= 2 {
            let (x, y) = self.targets(p_set, p_a);
            out[0] = (x - states[0]) / self.tau;
            out[1] = (y - states[1]) / self.tau;
        }
    }
    /// What the regulator holds at rest: the outlet at the set pressure, or
    /// at the supply's if that is lower (the supply passage then stays open).
    pub fn rest(&self, p_set: f64, ctx: &Ctx) -> RestPressure {
        RestPressure { port: 1, from: 0, pressure: p_set.min(ctx.pneumatic[0].p), relieving: self.relief.is_some() }
    }
    pub fn states(&self) -> &'static [StateSpec] {
        if self.tau > 0.0 {
            STATES
        } else {
            &[]
        }
    }
    pub fn ports(&self) -> &'static [PortSpec] {
        if self.relief.is_some() {
            PORTS_RELIEVING
        } else {
            PORTS_NON_RELIEVING
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PressureRegulator {
    pub p_set: f64,
    pub regulation: Regulation,
}

impl PressureRegulator {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(PressureRegulator { p_set: p.get("p_set"), regulation: Regulation::from_params(p)? })
    }
}

impl Block for PressureRegulator {
    fn type_name(&self) -> &'static str {
        "pressure_regulator"
    }
    fn ports(&self) -> &[PortSpec] {
        self.regulation.ports()
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(0, Fact::SetPressure(self.p_set))]
    }
    /// At rest the outlet stands at the set pressure (or the supply, if lower).
    fn rest_pressure(&self, ctx: &Ctx) -> Option<RestPressure> {
        Some(self.regulation.rest(self.p_set, ctx))
    }
    fn states(&self) -> &[StateSpec] {
        self.regulation.states()
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(1.0);
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        if states.len() >= 2 {
            let (x, y) = self.regulation.targets(self.p_set, ctx.pneumatic[1].p);
            states[0] = x;
            states[1] = y;
        }
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        self.regulation.flows(self.p_set, ctx, ctx.states, out);
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        self.regulation.partials(phase, self.p_set, &[], 0, ctx, d);
        true
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        self.regulation.derivatives(self.p_set, ctx.pneumatic[1].p, ctx.states, out);
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let (x, y) = self.regulation.openings(self.p_set, ctx.pneumatic[1].p, ctx.states);
        out[0] = Some(x);
        out[1] = Some(y);
    }
}

/// Registry entry of `pressure_regulator`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "pressure_regulator",
    family: crate::registry::Family::PressureValves,
    doc: "pressure regulator, relieving or not, flow-droop after ISO 6953",
    params: PARAMS,
    ports: PORTS_RELIEVING,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(PressureRegulator::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::iso6358::ANR_DENSITY;
    use crate::params::RawValue;
    use gas::GasModel;

    fn regulator(extra: &[(&str, &str)]) -> PressureRegulator {
        let mut raw = vec![
            ("p_set", RawValue::Text("4 bar".into())),
            ("C", RawValue::Text("10 L/min/bar".into())),
            ("b", RawValue::Number(0.3)),
            ("droop", RawValue::Text("0.3 bar".into())),
        ];
        raw.extend(extra.iter().map(|(k, v)| (*k, RawValue::Text(v.to_string()))));
        PressureRegulator::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap()
    }

    /// Flows into the regulator at (P, A, E) with the outlet at p_a.
    fn at(r: &PressureRegulator, p_supply: f64, p_a: f64) -> [PortFlow; 3] {
        let gas = gas::IdealGas::air();
        let n = [gas.state_pt(p_supply, 293.15), gas.state_pt(p_a, 293.15), gas.state_pt(1.01325e5, 293.15)];
        let mut out = [PortFlow::default(); 3];
        let k = r.ports().len();
        r.flows(&Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &n[..k], mechanical: &[], signals: &[] }, &mut out[..k]);
        out
    }

    /// Steady outlet pressure when the outlet delivers `mdot` (negative: gas pushed back in).
    fn outlet_pressure(r: &PressureRegulator, p_supply: f64, mdot: f64) -> f64 {
        // net flow the regulator delivers into the outlet node, minus the demand, falls with p_a
        let excess = |p: f64| {
            let f = at(r, p_supply, p);
            -f[1].mdot - mdot
        };
        let (mut lo, mut hi) = (1.02e5, p_supply.max(r.p_set * 1.5));
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if excess(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn flow_droop_characteristic_is_the_closed_form() {
        // ISO 6953-1 flow characteristic at 7 bar supply: with the supply passage
        // choked (p_A/p_P < b), p_A = p_set − Δp_droop·ṁ/(C ρ_ref K_T p_P)
        let r = regulator(&[("b", "0.6")]);
        let r = PressureRegulator { regulation: Regulation { supply: FlowCharacteristic::new(10e-3 / 60.0 / 1e5, 0.6).unwrap(), ..r.regulation }, ..r };
        let full = 10e-3 / 60.0 / 1e5 * ANR_DENSITY * 7e5;
        let mut last = f64::INFINITY;
        for frac in [0.0, 0.2, 0.5, 0.8, 0.95] {
            let pa = outlet_pressure(&r, 7e5, frac * full);
            let expected = 4e5 - 0.3e5 * frac;
            assert!((pa - expected).abs() < 1.0, "at {frac} of the full flow: {pa} vs {expected}");
            assert!(pa < last, "the outlet pressure falls with the flow");
            last = pa;
        }
    }

    #[test]
    fn relieving_vents_overpressure_and_non_relieving_holds_it() {
        let r = regulator(&[]);
        let f = at(&r, 7e5, 4.5e5);
        assert_eq!(f[0].mdot, 0.0, "supply closed above the set pressure");
        assert!(f[1].mdot > 0.0 && f[2].mdot < 0.0, "relief vents A to E");
        let n = regulator(&[("relieving", "no")]);
        assert_eq!(n.ports().len(), 2);
        let f = at(&n, 7e5, 4.5e5);
        assert_eq!((f[0].mdot, f[1].mdot), (0.0, 0.0));
        // dead band: neither passage is open between p_set and p_set + offset
        let f = at(&r, 7e5, 4.03e5);
        assert_eq!((f[0].mdot, f[2].mdot), (0.0, 0.0));
        // pushing gas back into the outlet: relief holds the outlet within offset + droop
        let pa = outlet_pressure(&r, 7e5, -0.5 * 10e-3 / 60.0 / 1e5 * ANR_DENSITY * 4e5);
        assert!(pa > 4.05e5 && pa < 4.35e5, "{pa}");
    }

    #[test]
    fn below_the_set_pressure_the_supply_passes_fully_open() {
        let r = regulator(&[]);
        let f = at(&r, 3e5, 1.5e5);
        let iso = FlowCharacteristic::new(10e-3 / 60.0 / 1e5, 0.3).unwrap().mass_flow(3e5, 293.15, 1.5e5, 293.15);
        assert!((f[0].mdot - iso).abs() < 1e-15);
    }
}
