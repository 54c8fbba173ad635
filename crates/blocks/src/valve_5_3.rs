//! 5/3 directional control valve: closed, exhaust or pressure centre;
//! spring-centred or detented; solenoid or pneumatic pilot actuation.
//!
//! ```text
//!            position 12        centre                 position 14
//!            P→B, A→EA    closed:   all ports blocked   P→A, B→EB
//!                         exhaust:  A→EA, B→EB (P blocked)
//!                         pressure: P→A, P→B (EA, EB blocked)
//! ```
//!
//! # Ports
//! - `P`, `A`, `B`, `EA`, `EB` — pneumatic, flow.
//! - solenoid actuation: `sol_14`, `sol_12` — signal inputs [1]: energised
//!   above 0.55, released below 0.45 (0/1 commands).
//! - pilot actuation: `pilot_14`, `pilot_12` — pneumatic, flow: pilot lines,
//!   read without flow; a pilot is on when its pressure exceeds that of
//!   `EA` by `pilot_pressure`, off below `pilot_pressure − pilot_hysteresis`.
//!
//! # Parameters (defaults in brackets)
//! - ISO 6358 set `C`, `b` (required), `m`, `b_lam`, `T_ref`, `rho_ref`: every
//!   open path; `C_exhaust`, `b_exhaust` [= C, b]: paths to EA and EB.
//! - `centre` [`closed`]: `closed`, `exhaust` or `pressure`.
//! - `return` [`spring`]: `spring` — centred whenever neither (or both)
//!   actuators act; `detent` — holds the last position reached until the
//!   other actuator acts (it starts in `initial_position`).
//! - `initial_position` [`centre`]: `centre`, `14` or `12` (detented valves).
//! - `actuation` [`solenoid`]: `solenoid` or `pilot`.
//! - `pilot_pressure` [Pa, 2 bar], `pilot_hysteresis` [Pa, 0.5 bar].
//! - `switching_time` [s, 0]: spool travel: 0 switches instantly, otherwise
//!   the spool position s ∈ [−1, 1] follows its target with a first-order lag
//!   of time constant switching_time/3 (95 % of the travel after it).
//! - `C_leak` [m³/(s Pa), 0]: leakage across each closed land (P–A, P–B,
//!   A–EA, B–EB), same b: a closed centre then lets the cylinder creep.
//!
//! # Equations
//! Each path is an ISO 6358 restriction (paper Eq. 33–35) scaled by its
//! opening: paths of position 14 by max(s, 0), of position 12 by
//! max(−s, 0), centre paths by 1 − |s|; energy flows carry the upstream
//! enthalpy. A land that is closed passes the leak flow (1 − o)·ṁ(C_leak).
//!
//! # Behaviour
//! The actuators' on/off states are discrete and change only at events
//! (root functions negative while a state stands, see
//! [`crate::support::switch_root`]), with hysteresis, so a slowly varying
//! command or pilot pressure cannot make the spool chatter.
//!
//! # Assumptions
//! No overlap or underlap besides the linear opening; pilot ports take no
//! flow; the pilot spool switches as a whole (no intermediate position).

use crate::block::*;
use crate::spool_paths::{self, Opening};
use crate::iso6358::FlowCharacteristic;
use crate::params::{ParamSpec, Params, Range};
use crate::support::{switch_root, switch_state};
use units::dim;

pub const PARAMS: &[ParamSpec] = crate::param_set!(
    crate::iso6358::PARAMS,
    &[
        ParamSpec::quantity("C_exhaust", dim::CONDUCTANCE, Some(0.0), Range::NonNegative, "L/min/bar", "paths to EA, EB (default: C)"),
        ParamSpec::quantity("b_exhaust", dim::DIMENSIONLESS, Some(0.0), Range::Closed(0.0, 0.999), "", "paths to EA, EB (default: b)"),
        ParamSpec::choice("centre", &["closed", "exhaust", "pressure"], 0, "centre position"),
        ParamSpec::choice("return", &["spring", "detent"], 0, "spring-centred, or holds its last position"),
        ParamSpec::choice("initial_position", &["centre", "14", "12"], 0, "starting position of a detented valve"),
        ParamSpec::choice("actuation", &["solenoid", "pilot"], 0, "signal inputs sol_14/sol_12, or pilot ports"),
        ParamSpec::quantity("pilot_pressure", dim::PRESSURE, Some(2e5), Range::Positive, "bar", "pilot pressure above EA that switches"),
        ParamSpec::quantity("pilot_hysteresis", dim::PRESSURE, Some(0.5e5), Range::Positive, "bar", "pilot pressure drop before release"),
        ParamSpec::quantity("switching_time", dim::TIME, Some(0.0), Range::NonNegative, "ms", "spool travel time (0 = instant)"),
        ParamSpec::quantity("C_leak", dim::CONDUCTANCE, Some(0.0), Range::NonNegative, "L/min/bar", "leakage across each closed land"),
    ]
);

const P: usize = 0;
const A: usize = 1;
const B: usize = 2;
const EA: usize = 3;
const EB: usize = 4;

pub const PORTS_SOLENOID: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port A (position 14: from P)"),
    PortSpec::new("B", PortKind::PneumaticFlow, "working port B (position 12: from P)"),
    PortSpec::new("EA", PortKind::PneumaticFlow, "exhaust of A"),
    PortSpec::new("EB", PortKind::PneumaticFlow, "exhaust of B"),
    PortSpec::signal("sol_14", PortKind::SignalIn, "1", "solenoid 14: 1 = shift to P->A"),
    PortSpec::signal("sol_12", PortKind::SignalIn, "1", "solenoid 12: 1 = shift to P->B"),
];
pub const PORTS_PILOT: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port A (position 14: from P)"),
    PortSpec::new("B", PortKind::PneumaticFlow, "working port B (position 12: from P)"),
    PortSpec::new("EA", PortKind::PneumaticFlow, "exhaust of A"),
    PortSpec::new("EB", PortKind::PneumaticFlow, "exhaust of B"),
    PortSpec::new("pilot_14", PortKind::PneumaticFlow, "pilot 14: pressure shifts to P->A (no flow)"),
    PortSpec::new("pilot_12", PortKind::PneumaticFlow, "pilot 12: pressure shifts to P->B (no flow)"),
];
/// Every port a 5/3 valve may have (for listings).
pub const PORTS_ALL: &[PortSpec] = &[
    PortSpec::new("P", PortKind::PneumaticFlow, "supply"),
    PortSpec::new("A", PortKind::PneumaticFlow, "working port A (position 14: from P)"),
    PortSpec::new("B", PortKind::PneumaticFlow, "working port B (position 12: from P)"),
    PortSpec::new("EA", PortKind::PneumaticFlow, "exhaust of A"),
    PortSpec::new("EB", PortKind::PneumaticFlow, "exhaust of B"),
    PortSpec::signal("sol_14", PortKind::SignalIn, "1", "solenoid 14 (actuation solenoid)"),
    PortSpec::signal("sol_12", PortKind::SignalIn, "1", "solenoid 12 (actuation solenoid)"),
    PortSpec::new("pilot_14", PortKind::PneumaticFlow, "pilot 14 (actuation pilot; no flow)"),
    PortSpec::new("pilot_12", PortKind::PneumaticFlow, "pilot 12 (actuation pilot; no flow)"),
];
const SPOOL_STATE: &[StateSpec] = &[StateSpec { name: "spool", unit: "1" }];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "spool", unit: "1" }];

/// Which openings a path follows.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Group {
    /// Open in position 14 (s > 0).
    Side14,
    /// Open in position 12 (s < 0).
    Side12,
    /// Open in the centre.
    Centre,
}

#[derive(Debug, Clone, PartialEq)]
struct Path {
    from: usize,
    to: usize,
    flow: FlowCharacteristic,
    group: Group,
    /// Leakage when closed (a land between ports), if any.
    leak: Option<FlowCharacteristic>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Valve53 {
    paths: Vec<Path>,
    pilot: bool,
    detent: bool,
    /// Lag time constant of the spool [s]; 0 = instant.
    spool_tau: f64,
    pilot_on: f64,
    pilot_off: f64,
    /// Actuator states (14, 12) as last accepted.
    pub actuated: [bool; 2],
    /// Position a detented spool holds: +1 (14), 0 (centre), −1 (12).
    pub held: f64,
}

impl Valve53 {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let supply = crate::iso6358::from_params(p, "C", "b")?;
        let exhaust = if p.was_given("C_exhaust") || p.was_given("b_exhaust") {
            let c = if p.was_given("C_exhaust") { p.get("C_exhaust") } else { p.get("C") };
            let b = if p.was_given("b_exhaust") { p.get("b_exhaust") } else { p.get("b") };
            crate::iso6358::with_shared(p, c, b)?
        } else {
            supply
        };
        let leak = if p.get("C_leak") > 0.0 { Some(crate::iso6358::with_shared(p, p.get("C_leak"), p.get("b"))?) } else { None };
        let path = |from, to, flow, group| Path { from, to, flow, group, leak };
        let centre = p.choice("centre");
        let mut paths = vec![path(P, A, supply, Group::Side14), path(B, EB, exhaust, Group::Side14)];
        paths.push(path(P, B, supply, Group::Side12));
        paths.push(path(A, EA, exhaust, Group::Side12));
        match centre {
            // the centre opens lands that are already listed: they are open in two positions
            1 => {
                paths.push(Path { leak: None, ..path(A, EA, exhaust, Group::Centre) });
                paths.push(Path { leak: None, ..path(B, EB, exhaust, Group::Centre) });
            }
            2 => {
                paths.push(Path { leak: None, ..path(P, A, supply, Group::Centre) });
                paths.push(Path { leak: None, ..path(P, B, supply, Group::Centre) });
            }
            _ => {}
        }
        let detent = p.choice("return") == 1;
        let held = match p.choice("initial_position") {
            1 => 1.0,
            2 => -1.0,
            _ => 0.0,
        };
        if !detent && p.was_given("initial_position") {
            return Err(crate::BlockError::invalid("initial_position", "applies to a detented valve (return = detent) only"));
        }
        let (on, hyst) = (p.get("pilot_pressure"), p.get("pilot_hysteresis"));
        if hyst >= on {
            return Err(crate::BlockError::invalid("pilot_hysteresis", "must be smaller than pilot_pressure"));
        }
        Ok(Valve53 {
            paths,
            pilot: p.choice("actuation") == 1,
            detent,
            spool_tau: p.get("switching_time") / 3.0,
            pilot_on: on,
            pilot_off: on - hyst,
            actuated: [false, false],
            held,
        })
    }

    /// Actuator drives as values crossing 0.5: solenoid commands, or pilot
    /// pressures mapped so that `pilot_on` is 0.55 and `pilot_off` 0.45.
    fn drives(&self, ctx: &Ctx) -> [f64; 2] {
        if self.pilot {
            let reference = ctx.pneumatic[EA].p;
            let scale = |p: f64| {
                let x = p - reference;
                crate::support::OFF_LEVEL + (x - self.pilot_off) / (self.pilot_on - self.pilot_off) * crate::support::HYSTERESIS
            };
            [scale(ctx.pneumatic[5].p), scale(ctx.pneumatic[6].p)]
        } else {
            [ctx.signals[0], ctx.signals[1]]
        }
    }

    /// Target spool position from the actuator states.
    fn target(&self) -> f64 {
        match self.actuated {
            [true, false] => 1.0,
            [false, true] => -1.0,
            _ if self.detent => self.held,
            _ => 0.0,
        }
    }

    /// Each path's opening: paths of position 14 by max(s, 0), of position
    /// 12 by max(−s, 0), centre paths by 1 − |s|. A lagged spool moves the
    /// openings; the switched target is piecewise constant.
    fn openings(&self, states: &[f64]) -> impl Iterator<Item = Opening<'_>> {
        let s = self.spool(states);
        let ds = match states.first() {
            Some(&x) if self.spool_tau > 0.0 && (-1.0..=1.0).contains(&x) => 1.0,
            _ => 0.0,
        };
        self.paths.iter().map(move |path| {
            let (opening, slope) = match path.group {
                Group::Side14 => (s.max(0.0), if s > 0.0 { ds } else { 0.0 }),
                Group::Side12 => ((-s).max(0.0), if s < 0.0 { -ds } else { 0.0 }),
                Group::Centre => (1.0 - s.abs(), -s.signum() * ds),
            };
            Opening { from: path.from, to: path.to, flow: &path.flow, leak: path.leak.as_ref(), opening, slope }
        })
    }

    /// Spool position in [−1, 1].
    pub fn spool(&self, states: &[f64]) -> f64 {
        if self.spool_tau > 0.0 {
            states.first().copied().unwrap_or(0.0).clamp(-1.0, 1.0)
        } else {
            self.target()
        }
    }
}

impl Block for Valve53 {
    fn type_name(&self) -> &'static str {
        "valve_5_3"
    }
    fn ports(&self) -> &[PortSpec] {
        if self.pilot {
            PORTS_PILOT
        } else {
            PORTS_SOLENOID
        }
    }
    fn gas_role(&self) -> GasRole {
        GasRole::Restriction
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        if self.pilot {
            Vec::new()
        } else {
            vec![(5, Fact::CommandThresholds { released: 0.0, actuated: 1.0 }), (6, Fact::CommandThresholds { released: 0.0, actuated: 1.0 })]
        }
    }
    fn states(&self) -> &[StateSpec] {
        if self.spool_tau > 0.0 {
            SPOOL_STATE
        } else {
            &[]
        }
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out.fill(1.0);
    }
    fn initial_states(&self, _ctx: &InitCtx, out: &mut [f64]) {
        if let Some(s) = out.first_mut() {
            *s = self.target();
        }
    }
    fn flows(&self, ctx: &Ctx, out: &mut [PortFlow]) {
        spool_paths::flows(self.openings(ctx.states), ctx, out);
    }
    fn port_flow(&self, ctx: &Ctx, port: usize) -> Option<(PortFlow, f64)> {
        Some(spool_paths::port_flow(self.openings(ctx.states), ctx, port))
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        match phase {
            Phase::Flows => spool_paths::flow_partials(self.openings(ctx.states), ctx, d),
            Phase::Derivatives if self.spool_tau > 0.0 => d.set(Out::Rate(0), In::State(0), -1.0 / self.spool_tau),
            _ => {}
        }
        true
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        if let (Some(d), Some(&s)) = (out.first_mut(), ctx.states.first()) {
            *d = (self.target() - s) / self.spool_tau;
        }
    }
    fn n_event_functions(&self) -> usize {
        2
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        let u = self.drives(ctx);
        out[0] = switch_root(self.actuated[0], u[0]);
        out[1] = switch_root(self.actuated[1], u[1]);
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        if !matches!(event, EventKind::Crossing(_)) {
            return EventOutcome::default();
        }
        let u = self.drives(ctx);
        let before = self.target();
        self.actuated = [switch_state(self.actuated[0], u[0]), switch_state(self.actuated[1], u[1])];
        if self.detent {
            self.held = self.target();
        }
        let after = self.target();
        let note = (after != before).then(|| {
            format!(
                "spool to {}",
                match after {
                    x if x > 0.0 => "14 (P->A)",
                    x if x < 0.0 => "12 (P->B)",
                    _ => "centre",
                }
            )
        });
        EventOutcome { cycle: None, note }
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.spool(ctx.states));
    }
}

/// Registry entry of `valve_5_3`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "valve_5_3",
    family: crate::registry::Family::DirectionalValves,
    doc: "5/3 valve: closed, exhaust or pressure centre; spring or detent; solenoid or pilot",
    params: PARAMS,
    ports: PORTS_ALL,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Valve53::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;
    use gas::{GasModel, GasState};

    fn valve(extra: &[(&str, &str)]) -> Valve53 {
        let mut raw = vec![("C", RawValue::Text("100 L/min/bar".into())), ("b", RawValue::Number(0.3))];
        raw.extend(extra.iter().map(|(k, v)| (*k, RawValue::Text(v.to_string()))));
        Valve53::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap()
    }

    fn nodes(gas: &dyn GasModel) -> [GasState; 7] {
        let s = |p| gas.state_pt(p, 293.15);
        // P 6 bar, A 3 bar, B 3 bar, exhausts 1 bar, pilots 1 bar
        [s(6e5), s(3e5), s(3e5), s(1e5), s(1e5), s(1e5), s(1e5)]
    }

    fn command(v: &mut Valve53, gas: &dyn GasModel, n: &[GasState], sol: [f64; 2]) {
        let ctx = Ctx { t: 0.0, gas, states: &[], pneumatic: n, mechanical: &[], signals: &sol };
        let mut g = [0.0; 2];
        v.event_functions(&ctx, &mut g);
        if g.iter().any(|&x| x > 0.0) {
            v.on_event(EventKind::Crossing(0), &ctx);
        }
        v.event_functions(&ctx, &mut g);
        assert!(g.iter().all(|&x| x <= 0.0));
    }

    fn flows(v: &Valve53, gas: &dyn GasModel, n: &[GasState], sol: [f64; 2]) -> Vec<f64> {
        let mut out = [PortFlow::default(); 7];
        v.flows(&Ctx { t: 0.0, gas, states: &[], pneumatic: n, mechanical: &[], signals: &sol }, &mut out);
        let total: f64 = out.iter().map(|f| f.mdot).sum();
        assert!(total.abs() < 1e-15, "mass is conserved inside the valve");
        out.iter().map(|f| f.mdot).collect()
    }

    #[test]
    fn port_flow_slopes_match_finite_differences() {
        let gas = gas::IdealGas::air();
        let s = |p| gas.state_pt(p, 293.15);
        // P 6 bar, A 3.99 bar (subsonic towards it), B 2 bar, exhausts 1 bar
        let n = [s(6e5), s(3.99e5), s(2e5), s(1e5), s(1.0001e5), s(1e5), s(1e5)];
        for centre in ["closed", "exhaust", "pressure"] {
            let v = valve(&[("centre", centre), ("C_leak", "0.5 L/min/bar"), ("switching_time", "10 ms")]);
            for x in [-1.0, -0.4, 0.0, 0.3, 1.0] {
                crate::speed_control_valve::slope_tests::check_port_flow_slopes(&v, &[x], &[0.0, 0.0], &n);
            }
        }
    }

    #[test]
    fn centres_route_as_their_symbols_say() {
        let gas = gas::IdealGas::air();
        let n = nodes(&gas);
        let closed = flows(&valve(&[]), &gas, &n, [0.0, 0.0]);
        assert!(closed.iter().all(|&m| m == 0.0), "closed centre blocks every port: {closed:?}");
        let exhaust = flows(&valve(&[("centre", "exhaust")]), &gas, &n, [0.0, 0.0]);
        assert!(exhaust[P] == 0.0 && exhaust[A] > 0.0 && exhaust[B] > 0.0 && exhaust[EA] < 0.0 && exhaust[EB] < 0.0);
        let pressure = flows(&valve(&[("centre", "pressure")]), &gas, &n, [0.0, 0.0]);
        assert!(pressure[P] > 0.0 && pressure[A] < 0.0 && pressure[B] < 0.0 && pressure[EA] == 0.0);
        // the exhaust centre vents A exactly as position 12 does (same path, same characteristic)
        let mut v = valve(&[]);
        command(&mut v, &gas, &n, [0.0, 1.0]);
        let side12 = flows(&v, &gas, &n, [0.0, 1.0]);
        assert_eq!(side12[A], exhaust[A]);
        assert!(side12[P] > 0.0 && side12[B] < 0.0 && side12[A] > 0.0 && side12[EA] < 0.0 && side12[EB] == 0.0);
    }

    #[test]
    fn spring_centres_and_detent_holds() {
        let gas = gas::IdealGas::air();
        let n = nodes(&gas);
        let mut spring = valve(&[]);
        let mut detent = valve(&[("return", "detent")]);
        for v in [&mut spring, &mut detent] {
            command(v, &gas, &n, [1.0, 0.0]);
            assert_eq!(v.target(), 1.0);
        }
        command(&mut spring, &gas, &n, [0.0, 0.0]);
        command(&mut detent, &gas, &n, [0.0, 0.0]);
        assert_eq!(spring.target(), 0.0, "spring-centred");
        assert_eq!(detent.target(), 1.0, "detented: holds 14");
        command(&mut detent, &gas, &n, [0.0, 1.0]);
        command(&mut detent, &gas, &n, [0.0, 0.0]);
        assert_eq!(detent.target(), -1.0);
        // both solenoids: a spring-centred valve centres, a detented one stays
        command(&mut spring, &gas, &n, [1.0, 1.0]);
        command(&mut detent, &gas, &n, [1.0, 1.0]);
        assert_eq!((spring.target(), detent.target()), (0.0, -1.0));
    }

    #[test]
    fn pilot_switches_with_hysteresis_and_takes_no_flow() {
        let gas = gas::IdealGas::air();
        let mut v = valve(&[("actuation", "pilot"), ("pilot_pressure", "2 bar"), ("pilot_hysteresis", "0.5 bar")]);
        assert_eq!(v.ports().len(), 7);
        let mut n = nodes(&gas);
        for (p14, want) in [(2.9e5, false), (3.1e5, true), (2.6e5, true), (2.4e5, false)] {
            n[5] = gas.state_pt(p14, 293.15);
            command(&mut v, &gas, &n, [0.0, 0.0]);
            assert_eq!(v.actuated[0], want, "pilot at {p14} Pa");
        }
        let f = flows(&v, &gas, &n, [0.0, 0.0]);
        assert_eq!((f[5], f[6]), (0.0, 0.0));
    }

    #[test]
    fn closed_centre_leaks_only_through_c_leak() {
        let gas = gas::IdealGas::air();
        let n = nodes(&gas);
        let tight = flows(&valve(&[]), &gas, &n, [0.0, 0.0]);
        let leaky = flows(&valve(&[("C_leak", "0.1 L/min/bar")]), &gas, &n, [0.0, 0.0]);
        assert!(tight[A] == 0.0 && leaky[A] != 0.0);
        // the leak from P into A is the ISO flow of C_leak (subsonic at 3/6 bar with b = 0.3)
        let leak = FlowCharacteristic::new(0.1e-3 / 60.0 / 1e5, 0.3).unwrap();
        let p_to_a = leak.mass_flow(6e5, 293.15, 3e5, 293.15);
        let a_to_ea = leak.mass_flow(3e5, 293.15, 1e5, 293.15);
        assert!((-leaky[A] - (p_to_a - a_to_ea)).abs() < 1e-15, "{} vs {}", -leaky[A], p_to_a - a_to_ea);
    }

    #[test]
    fn spool_lag_moves_between_positions() {
        let gas = gas::IdealGas::air();
        let n = nodes(&gas);
        let mut v = valve(&[("switching_time", "30 ms")]);
        command(&mut v, &gas, &n, [0.0, 1.0]);
        let mut d = [0.0];
        v.derivatives(
            &Ctx { t: 0.0, gas: &gas, states: &[0.0], pneumatic: &n, mechanical: &[], signals: &[0.0, 1.0] },
            &Balances { pneumatic: &[], mechanical: &[] },
            &mut d,
        );
        assert!((d[0] + 1.0 / 0.01).abs() < 1e-9);
        // half way to 12: both the centre (closed: nothing) and side 12 at half opening
        let mut out = [PortFlow::default(); 7];
        v.flows(&Ctx { t: 0.0, gas: &gas, states: &[-0.5], pneumatic: &n, mechanical: &[], signals: &[0.0, 1.0] }, &mut out);
        let full = FlowCharacteristic::new(100e-3 / 60.0 / 1e5, 0.3).unwrap().mass_flow(6e5, 293.15, 3e5, 293.15);
        assert!((out[P].mdot - 0.5 * full).abs() < 1e-12);
    }
}
