//! External load on a cylinder rod: gravity by mounting angle, a force
//! profile from a table (over position or over time), and a carried mass
//! that may change during the run (a part placed on or taken off).
//!
//! # Ports
//! - `rod` — mechanical, force: acts on the moving mass.
//!
//! # Parameters (defaults in brackets)
//! - `mass` [kg, 0, ≥ 0]: mass carried by the rod; it adds to the node's
//!   moving mass (inertia) and, with the angle, to its weight.
//! - `angle` [rad, 0, within ±90°]: mounting angle of the extend direction
//!   above the horizontal ("90 deg": vertical, extending lifts the load;
//!   "-90 deg": hanging, extending lowers it).
//! - `g` [m/s², 9.806 65]: gravitational acceleration (standard gravity).
//! - `forces` [N, list]: force profile, positive in the extend direction,
//!   at the points of `force_positions` [m, list] (a spring-back, a
//!   pressing operation) or of `force_times` [s, list] (a process force);
//!   linear between points, held beyond the ends. Give one of the two.
//! - `mass_after` [kg, ≥ 0] and `mass_change_time` [s]: the carried mass
//!   becomes `mass_after` at that instant (both or neither).
//!
//! # Equations
//! F = −m·g·sin(α) + F_table(x or t) on the node (weight resolved along the
//! cylinder axis; Newton's second law with the node mass M + m, the piston's
//! mass M).
//!
//! # Assumptions
//! Rigid attachment. At a mass change the velocity is kept: right for a
//! part released from a moving rod, and for one placed while the rod is at
//! rest; a part picked up in motion (an inelastic impact) is not modelled.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use crate::support::interpolate;
use units::dim;

/// Standard acceleration of gravity [m/s²] (CGPM 1901, ISO 80000-3).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("mass", dim::MASS, Some(0.0), Range::NonNegative, "kg", "carried mass (adds inertia and weight)"),
    ParamSpec::quantity(
        "angle",
        dim::DIMENSIONLESS,
        Some(0.0),
        Range::Closed(-std::f64::consts::FRAC_PI_2 - 1e-12, std::f64::consts::FRAC_PI_2 + 1e-12),
        "deg",
        "extend direction above the horizontal (90 deg = lifting)",
    ),
    ParamSpec::quantity("g", dim::ACCELERATION, Some(STANDARD_GRAVITY), Range::NonNegative, "m/s^2", "gravitational acceleration"),
    ParamSpec::list("forces", dim::FORCE, Range::Any, "N", "force profile values (extend direction positive)"),
    ParamSpec::list("force_positions", dim::LENGTH, Range::Any, "mm", "positions of the force profile (increasing)"),
    ParamSpec::list("force_times", dim::TIME, Range::NonNegative, "s", "times of the force profile (increasing)"),
    ParamSpec::quantity("mass_after", dim::MASS, Some(0.0), Range::NonNegative, "kg", "carried mass after the change"),
    ParamSpec::quantity("mass_change_time", dim::TIME, Some(0.0), Range::NonNegative, "s", "instant of the mass change"),
];
pub const PORTS: &[PortSpec] = &[PortSpec::new("rod", PortKind::MechanicalForce, "load on the moving mass")];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "F", unit: "N" }, OutputSpec { name: "mass", unit: "kg" }];

/// What the force table is a function of.
#[derive(Debug, Clone, PartialEq)]
pub enum Profile {
    None,
    Position(Vec<f64>, Vec<f64>),
    Time(Vec<f64>, Vec<f64>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Load {
    /// Carried mass now [kg].
    pub mass: f64,
    pub sin_angle: f64,
    pub g: f64,
    pub profile: Profile,
    /// Pending mass change (time, new mass).
    pub change: Option<(f64, f64)>,
}

fn increasing(xs: &[f64]) -> bool {
    xs.windows(2).all(|w| w[1] > w[0])
}

impl Load {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let forces = p.list("forces").to_vec();
        let (xs, ts) = (p.list("force_positions").to_vec(), p.list("force_times").to_vec());
        let profile = match (xs.is_empty(), ts.is_empty()) {
            (true, true) if forces.is_empty() => Profile::None,
            (true, true) => return Err(crate::BlockError::invalid("forces", "needs force_positions or force_times")),
            (false, false) => return Err(crate::BlockError::invalid("force_times", "give force_positions or force_times, not both")),
            (false, true) => Profile::Position(xs, forces.clone()),
            (true, false) => Profile::Time(ts, forces.clone()),
        };
        if let Profile::Position(at, f) | Profile::Time(at, f) = &profile {
            let name = if matches!(profile, Profile::Position(..)) { "force_positions" } else { "force_times" };
            if at.len() != f.len() {
                return Err(crate::BlockError::invalid("forces", &format!("has {} values but {name} has {}", f.len(), at.len())));
            }
            if !increasing(at) {
                return Err(crate::BlockError::invalid(name, "must be strictly increasing"));
            }
        }
        let change = match (p.was_given("mass_after"), p.was_given("mass_change_time")) {
            (true, true) => Some((p.get("mass_change_time"), p.get("mass_after"))),
            (false, false) => None,
            (true, false) => return Err(crate::BlockError::invalid("mass_change_time", "is needed with mass_after")),
            (false, true) => return Err(crate::BlockError::invalid("mass_after", "is needed with mass_change_time")),
        };
        Ok(Load { mass: p.get("mass"), sin_angle: p.get("angle").sin(), g: p.get("g"), profile, change })
    }
    /// Force on the node at position x and time t [N].
    pub fn force(&self, x: f64, t: f64) -> f64 {
        let table = match &self.profile {
            Profile::None => 0.0,
            Profile::Position(xs, fs) => interpolate(xs, fs, x),
            Profile::Time(ts, fs) => interpolate(ts, fs, t),
        };
        -self.mass * self.g * self.sin_angle + table
    }
}

impl Block for Load {
    fn type_name(&self) -> &'static str {
        "load"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn forces(&self, ctx: &Ctx, out: &mut [PortForce]) {
        out[0] = PortForce { applied: self.force(ctx.mechanical[0].x, ctx.t), friction: None };
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if let (Phase::Forces, Profile::Position(xs, fs)) = (phase, &self.profile) {
            d.set(Out::Applied(0), In::X(0), crate::support::interpolate_slope(xs, fs, ctx.mechanical[0].x));
        }
        true
    }
    fn carried_mass(&self) -> f64 {
        self.mass
    }
    fn time_dependent(&self) -> bool {
        matches!(self.profile, Profile::Time(..))
    }
    fn next_time_event(&self, t: f64) -> Option<f64> {
        // the mass change, and the corners of a time profile (the force is only piecewise smooth)
        let corner = match &self.profile {
            Profile::Time(ts, _) => ts.iter().copied().find(|&ti| ti > t),
            _ => None,
        };
        let change = self.change.map(|c| c.0).filter(|&tc| tc > t);
        match (corner, change) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }
    fn on_event(&mut self, event: EventKind, ctx: &Ctx) -> EventOutcome {
        if let (EventKind::Time, Some((tc, m))) = (event, self.change) {
            if (ctx.t - tc).abs() <= 1e-12 * tc.max(1.0) || ctx.t >= tc {
                self.mass = m;
                self.change = None;
                return EventOutcome { cycle: None, note: Some(format!("carried mass now {m} kg")) };
            }
        }
        EventOutcome::default()
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(self.force(ctx.mechanical[0].x, ctx.t));
        out[1] = Some(self.mass);
    }
}

/// Registry entry of `load`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "load",
    family: crate::registry::Family::Mechanics,
    doc: "external load: gravity by mounting angle, force table, mass change",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Load::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;

    fn build(raw: &[(&str, RawValue)]) -> Result<Load, crate::BlockError> {
        Load::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v)))?)
    }

    #[test]
    fn weight_along_the_axis_follows_the_mounting_angle() {
        let vertical = build(&[("mass", RawValue::Text("50 kg".into())), ("angle", RawValue::Text("90 deg".into()))]).unwrap();
        assert!((vertical.force(0.0, 0.0) + 50.0 * STANDARD_GRAVITY).abs() < 1e-9);
        assert_eq!(vertical.carried_mass(), 50.0);
        let inclined = build(&[("mass", RawValue::Text("50 kg".into())), ("angle", RawValue::Text("30 deg".into()))]).unwrap();
        assert!((inclined.force(0.0, 0.0) + 25.0 * STANDARD_GRAVITY).abs() < 1e-9);
        let hanging = build(&[("mass", RawValue::Number(2.0)), ("angle", RawValue::Text("-90 deg".into()))]).unwrap();
        assert!(hanging.force(0.0, 0.0) > 0.0, "a hanging load pulls in the extend direction");
        assert!(build(&[("angle", RawValue::Text("120 deg".into()))]).is_err());
    }

    #[test]
    fn force_table_over_position_and_time() {
        let l = build(&[
            ("forces", RawValue::Text("0 N, -200 N, -200 N".into())),
            ("force_positions", RawValue::Text("100 mm, 110 mm, 200 mm".into())),
        ])
        .unwrap();
        assert_eq!(l.force(0.05, 0.0), 0.0);
        assert!((l.force(0.105, 0.0) + 100.0).abs() < 1e-9);
        assert_eq!(l.force(0.3, 0.0), -200.0);
        let l = build(&[("forces", RawValue::Text("0, 50 N".into())), ("force_times", RawValue::Text("1 s, 2 s".into()))]).unwrap();
        assert!((l.force(0.0, 1.5) - 25.0).abs() < 1e-9);
        assert!(l.time_dependent());
        assert_eq!(l.next_time_event(0.0), Some(1.0));
        let e = build(&[("forces", RawValue::Text("0, 50 N".into()))]).unwrap_err().to_string();
        assert!(e.contains("forces"), "{e}");
        let e = build(&[("forces", RawValue::Text("0".into())), ("force_times", RawValue::Text("1 s, 2 s".into()))]).unwrap_err().to_string();
        assert!(e.contains("forces"), "{e}");
    }

    #[test]
    fn mass_changes_at_its_instant() {
        let gas = gas::IdealGas::air();
        let mut l = build(&[
            ("mass", RawValue::Number(5.0)),
            ("mass_after", RawValue::Number(1.0)),
            ("mass_change_time", RawValue::Text("2 s".into())),
        ])
        .unwrap();
        assert_eq!(l.next_time_event(0.0), Some(2.0));
        let m = [MechState::default()];
        l.on_event(EventKind::Time, &Ctx { t: 2.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &m, signals: &[] });
        assert_eq!(l.carried_mass(), 1.0);
        assert_eq!(l.next_time_event(2.0), None);
        assert!(build(&[("mass_after", RawValue::Number(1.0))]).is_err());
    }
}
