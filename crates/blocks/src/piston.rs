//! Piston: the moving mass of a cylinder, with end stops.
//!
//! # Ports
//! - `rod` — mechanical, inertia: imposes position x and velocity v on the
//!   mechanical node it shares with the chamber faces, friction and loads.
//! - `x` [m], `v` [m/s] — signal outputs.
//!
//! # Parameters (defaults in brackets)
//! - `mass` [kg, required]: moving mass M (piston, rod and load).
//! - `stroke` [m, required]: stops at x = 0 and x = stroke.
//! - `rod_area` [m², 0] or `rod_diameter` [m, 0]: rod cross-section exposed to
//!   the atmosphere; the atmosphere pushes it with −p_atm·A_rod.
//! - `p_atm` [Pa, 101 325 Pa]: ambient pressure on the rod.
//! - `external_force` [N, 0]: constant load, positive in the extend direction;
//!   live: an interface input may drive it (piecewise constant).
//! - `restitution` [-, 0]: coefficient of restitution at the stops
//!   (0 = inelastic, the paper's assumption).
//! - initial conditions `x0` [m, 0], `v0` [m/s, 0].
//!
//! # Equations
//! Newton's law on the rigid mechanical node (a 1-junction in bond-graph
//! terms): M·ẍ = Σ F_applied − F_friction, ẋ = v. The acceleration is decided
//! by the node logic in `solve` (stick–slip after Karnopp 1985, stops), which
//! knows this block only through [`Block::inertia`] and [`Block::stops`]:
//! at a stop or while stuck, ẍ = 0 and v = 0 exactly; an impact at speed v
//! sets v ← −e·v.
//!
//! # Assumptions
//! Rigid rod and load; stops are ideal (no compliance).

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("mass", dim::MASS, None, Range::Positive, "kg", "moving mass"),
    ParamSpec::quantity("stroke", dim::LENGTH, None, Range::Positive, "mm", "stroke length"),
    ParamSpec::quantity("rod_area", dim::AREA, Some(0.0), Range::NonNegative, "cm2", "rod area exposed to the atmosphere"),
    ParamSpec::quantity("rod_diameter", dim::LENGTH, Some(0.0), Range::NonNegative, "mm", "rod diameter (alternative to rod_area)"),
    ParamSpec::quantity("p_atm", dim::PRESSURE, Some(101_325.0), Range::AbsolutePressure, "bar", "ambient pressure on the rod"),
    ParamSpec::quantity("external_force", dim::FORCE, Some(0.0), Range::Any, "N", "constant load, positive in the extend direction"),
    ParamSpec::quantity(
        "restitution",
        dim::DIMENSIONLESS,
        Some(0.0),
        Range::Closed(0.0, 1.0),
        "",
        "coefficient of restitution at the stops",
    ),
    ParamSpec::quantity("x0", dim::LENGTH, Some(0.0), Range::Any, "mm", "initial position"),
    ParamSpec::quantity("v0", dim::VELOCITY, Some(0.0), Range::Any, "m/s", "initial velocity"),
];

pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalInertia, "the moving mass"),
    PortSpec::signal("x", PortKind::SignalOut, "m", "position"),
    PortSpec::signal("v", PortKind::SignalOut, "m/s", "velocity"),
];
const STATES: &[StateSpec] = &[StateSpec { name: "x", unit: "m" }, StateSpec { name: "v", unit: "m/s" }];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "a", unit: "m/s2" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Piston {
    pub mass: f64,
    pub stroke: f64,
    pub rod_area: f64,
    pub p_atm: f64,
    pub external_force: f64,
    pub restitution: f64,
    pub x0: f64,
    pub v0: f64,
    /// Whether x0 (and v0) were left to their defaults (a rest state may set x0).
    pub free_position: bool,
    /// Rod diameter [m], when the rod area was given that way.
    pub rod_diameter: Option<f64>,
}

impl Piston {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let rod_area = if p.was_given("rod_diameter") {
            if p.was_given("rod_area") {
                return Err(crate::BlockError::invalid("rod_area", "give either rod_area or rod_diameter, not both"));
            }
            let d = p.get("rod_diameter");
            std::f64::consts::PI / 4.0 * d * d
        } else {
            p.get("rod_area")
        };
        let s = Piston {
            mass: p.get("mass"),
            stroke: p.get("stroke"),
            rod_area,
            p_atm: p.get("p_atm"),
            external_force: p.get("external_force"),
            restitution: p.get("restitution"),
            x0: p.get("x0"),
            v0: p.get("v0"),
            free_position: !p.was_given("x0") && !p.was_given("v0"),
            rod_diameter: p.was_given("rod_diameter").then(|| p.get("rod_diameter")),
        };
        if s.x0 < 0.0 || s.x0 > s.stroke {
            return Err(crate::BlockError::invalid("x0", "must lie between 0 and the stroke"));
        }
        Ok(s)
    }
}

impl Block for Piston {
    fn type_name(&self) -> &'static str {
        "piston"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn states(&self) -> &[StateSpec] {
        STATES
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out[0] = self.stroke;
        out[1] = 1.0;
    }
    fn free_initial(&self) -> FreeInitial {
        FreeInitial { position: self.free_position, ..FreeInitial::default() }
    }
    fn set_initial_position(&mut self, x: f64) {
        self.x0 = x.clamp(0.0, self.stroke);
        self.v0 = 0.0;
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        let mut f = vec![(0, Fact::Stroke(self.stroke))];
        if let Some(d) = self.rod_diameter {
            f.push((0, Fact::RodDiameter(d)));
        }
        f
    }
    fn initial_states(&self, _ctx: &InitCtx, out: &mut [f64]) {
        out[0] = self.x0;
        out[1] = self.v0;
    }
    fn kinematics(&self, states: &[f64], out: &mut [MechState]) {
        out[0] = MechState { x: states[0], v: states[1] };
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = ctx.states[0];
        out[1] = ctx.states[1];
    }
    /// An external force an interface input drives (a process force, a disturbance).
    fn live_parameters(&self) -> &'static [&'static str] {
        &["external_force"]
    }
    fn set_live_parameter(&mut self, name: &str, value: f64) {
        if name == "external_force" {
            self.external_force = value;
        }
    }
    /// The applied force is F_ext − p_atm·A_rod: ∂F/∂F_ext = 1.
    fn live_partials(&self, name: &str, phase: Phase, _ctx: &Ctx, out: &mut [f64]) -> bool {
        if name == "external_force" && phase == Phase::Forces {
            out[0] = 1.0;
        }
        name == "external_force"
    }
    fn forces(&self, _ctx: &Ctx, out: &mut [PortForce]) {
        out[0] = PortForce { applied: self.external_force - self.p_atm * self.rod_area, friction: None };
    }
    fn partials(&self, phase: Phase, _ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        match phase {
            Phase::Kinematics => {
                d.set(Out::X(0), In::State(0), 1.0);
                d.set(Out::V(0), In::State(1), 1.0);
            }
            Phase::Signals => {
                d.set(Out::Signal(0), In::State(0), 1.0);
                d.set(Out::Signal(1), In::State(1), 1.0);
            }
            Phase::Derivatives => {
                d.set(Out::Rate(0), In::State(1), 1.0);
                d.set(Out::Rate(1), In::Accel(0), 1.0);
            }
            _ => {} // the applied force is constant
        }
        true
    }
    fn inertia(&self) -> f64 {
        self.mass
    }
    fn stops(&self) -> Option<Stops> {
        Some(Stops { lower: 0.0, upper: self.stroke, restitution: self.restitution })
    }
    fn reset_motion(&self, states: &mut [f64], motion: MechState) {
        states[0] = motion.x;
        states[1] = motion.v;
    }
    fn derivatives(&self, ctx: &Ctx, balances: &Balances, out: &mut [f64]) {
        out[0] = ctx.states[1];
        out[1] = balances.mechanical[0].accel;
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, _ctx: &Ctx, balances: &Balances, _derivs: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(balances.mechanical[0].accel);
    }
}

/// Registry entry of `piston`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "piston",
    family: crate::registry::Family::Mechanics,
    doc: "moving mass with end stops",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Piston::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;

    fn build(raw: &[(&str, RawValue)]) -> Result<Piston, crate::BlockError> {
        let p = Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v)))?;
        Piston::from_params(&p)
    }

    #[test]
    fn rod_force_is_atmosphere_on_rod_area() {
        let p = build(&[
            ("mass", RawValue::Number(1.0)),
            ("stroke", RawValue::Text("450 mm".into())),
            ("rod_diameter", RawValue::Text("15 mm".into())),
            ("p_atm", RawValue::Text("0.98 bar".into())),
        ])
        .unwrap();
        let a = std::f64::consts::PI / 4.0 * 0.015f64.powi(2);
        assert!((p.rod_area - a).abs() < 1e-15);
        let gas = gas::IdealGas::air();
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[0.0, 0.0], pneumatic: &[], mechanical: &[MechState::default()], signals: &[] };
        let mut f = [PortForce::default()];
        p.forces(&ctx, &mut f);
        assert!((f[0].applied + 98_000.0 * a).abs() < 1e-9);
        assert_eq!(p.stops().unwrap().upper, 0.45);
    }

    #[test]
    fn rejects_start_outside_stroke_and_double_rod_spec() {
        let base = [("mass", RawValue::Number(1.0)), ("stroke", RawValue::Number(0.1))];
        let mut bad = base.to_vec();
        bad.push(("x0", RawValue::Number(0.2)));
        assert!(build(&bad).unwrap_err().to_string().contains("x0"));
        let mut bad = base.to_vec();
        bad.push(("rod_area", RawValue::Number(1e-4)));
        bad.push(("rod_diameter", RawValue::Number(0.01)));
        assert!(build(&bad).is_err());
        assert!(build(&[("mass", RawValue::Number(1.0))]).unwrap_err().to_string().contains("stroke"));
    }
}
