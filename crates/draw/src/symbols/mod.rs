//! The symbol of every block type, after ISO 1219-1, by family: sources
//! and exhausts, lines and restrictions, valves, actuators, sensors and
//! control blocks. [`block_symbol`] chooses the one for a block type;
//! cylinders (a piston with its chambers, friction, springs, loads,
//! cushions, sensors and switches) are drawn as one symbol by
//! [`actuators::cylinder`].
//!
//! A builder receives the block's parameters as validated by the block
//! library (SI values, choices, words) and returns a [`Shape`] whose label
//! lines hold the key parameters in engineering units; the caller adds the
//! id as the first line.

pub mod actuators;
pub mod control;
pub mod flow;
pub mod pressure;
pub mod sensors;
pub mod sources;
pub mod valves;

use crate::format;
use crate::shape::Shape;
use blocks::block::PortSpec;
use blocks::params::{ParamKind, Params};
use blocks::registry::BlockType;
use std::collections::BTreeSet;

/// One block of an item, as a symbol builder sees it.
pub struct Member<'a> {
    /// Full id (`cyl.head`).
    pub id: &'a str,
    pub ty: &'static BlockType,
    pub params: &'a Params,
    /// The ports of the built block (a sequencer's are named by its parameters).
    pub ports: &'a [PortSpec],
}

impl Member<'_> {
    /// SI value of a numeric parameter.
    pub fn get(&self, name: &str) -> f64 {
        self.params.get(name)
    }
    /// The word of a choice parameter ("closed", "yes").
    pub fn word(&self, name: &str) -> &'static str {
        let index = self.params.choice(name);
        self.ty
            .params
            .iter()
            .find(|p| p.name == name)
            .and_then(|p| if let ParamKind::Choice(options) = p.kind { options.get(index).copied() } else { None })
            .unwrap_or("")
    }
    /// A parameter in its display unit ("13.2 L/min/bar").
    pub fn show(&self, name: &str) -> String {
        let unit = self.ty.params.iter().find(|p| p.name == name).map(|p| p.display_unit).unwrap_or("");
        format::quantity(self.get(name), unit)
    }
    /// "name value" for a label line.
    pub fn named(&self, label: &str, name: &str) -> String {
        format!("{label} {}", self.show(name))
    }
    pub fn given(&self, name: &str) -> bool {
        self.params.was_given(name)
    }
    pub fn has_port(&self, name: &str) -> bool {
        self.ports.iter().any(|p| p.name == name)
    }
    /// The ISO 6358 pair "C 13.2 L/min/bar, b 0.3".
    pub fn iso6358(&self) -> String {
        format!("C {}, b {}", self.show("C"), format::sig(self.get("b"), 3))
    }
}

/// What an item's builder needs besides its members.
pub struct Ctx<'a> {
    pub members: &'a [Member<'a>],
    /// Ports (member index, port name) connected to something outside the
    /// item: optional pins (a chamber's pressure signal, a piston's
    /// position) are drawn only for these.
    pub used: &'a BTreeSet<(usize, String)>,
    /// Draw the symbol upside down (its `b` side at the bottom): chosen by
    /// the layout so that air flows upwards from the supply.
    pub flip: bool,
}

impl Ctx<'_> {
    pub fn used(&self, member: usize, port: &str) -> bool {
        self.used.contains(&(member, port.to_string()))
    }
}

/// The two ports of a symbol the layout may turn upside down, bottom one
/// first as drawn unflipped; `None` for symbols with a fixed orientation.
pub fn flippable(kind: &str) -> Option<(&'static str, &'static str)> {
    match kind {
        "conductance" | "capillary" | "check_valve" | "speed_control_valve" | "tube" | "flow_sensor" => Some(("a", "b")),
        "valve_2_2" => Some(("a", "b")),
        _ => None,
    }
}

/// The symbol of a single block, or `None` for a type this module does not
/// know (drawn as a plain labelled box by the caller).
pub fn block_symbol(ctx: &Ctx) -> Option<Shape> {
    let m = &ctx.members[0];
    let mut shape = match m.ty.name {
        "pressure_source" => sources::pressure_source(m),
        "atmosphere" => sources::atmosphere(m),
        "mass_flow_source" => sources::mass_flow_source(m),
        "chamber" => actuators::tank(ctx),
        "tube" => flow::tube(m),
        "conductance" => flow::conductance(m),
        "capillary" => flow::capillary(m),
        "check_valve" => flow::check_valve(m),
        "speed_control_valve" => flow::speed_control(m),
        "valve_5_2" | "valve_3_2" | "valve_2_2" | "valve_5_3" | "proportional_valve" => valves::directional(m),
        "pressure_regulator" | "proportional_pressure_valve" => pressure::regulator(m),
        "relief_valve" => pressure::relief(m),
        "quick_exhaust_valve" => flow::quick_exhaust(m),
        "shuttle_valve" | "two_pressure_valve" => flow::shuttle(m),
        "piston" | "friction" | "spring" | "load" | "cushion" => actuators::mechanical(ctx),
        "pressure_sensor" | "temperature_sensor" => sensors::gauge(m),
        "flow_sensor" => sensors::flow_meter(m),
        "position_sensor" | "velocity_sensor" | "limit_switch" => sensors::on_rod(m),
        "schedule" | "cycler" | "delay" | "sequencer" | "timer" | "logic_gate" | "pid" => control::block(m),
        _ => return None,
    };
    if ctx.flip && flippable(m.ty.name).is_some() {
        shape.flip_vertically();
    }
    Some(shape)
}

/// A plain box with a pin for every port, for a block type without a symbol.
pub fn generic(ctx: &Ctx) -> Shape {
    let m = &ctx.members[0];
    control::boxed(m, m.ty.name, &[])
}
