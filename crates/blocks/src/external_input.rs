//! External input: the signal source behind an interface input of a netlist.
//!
//! Not a block type a netlist names: `graph` creates one for each interface
//! input bound to signal ports (`"port": "dcv.command"`) and wires its
//! output to those ports, in place of the signal they read inside the
//! netlist when the model is driven from outside (an FMU, a linearisation),
//! or as their only source when nothing inside drives them.
//!
//! # Ports
//! - `value` — signal output: the input's current value, in SI units (the
//!   unit of the ports it drives).
//!
//! # Parameters
//! - `value` (live): the held value. It starts at the input's start value
//!   and changes only between integration steps ([`Block::set_live_parameter`]),
//!   so the output is piecewise constant — what a co-simulation master
//!   holds over a communication step.

use crate::block::*;

/// The live parameter that holds the value.
pub const VALUE: &str = "value";

const PORTS: &[PortSpec] = &[PortSpec::signal("value", PortKind::SignalOut, "", "the input's value (SI)")];

/// Source of an interface input's value (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct ExternalInput {
    pub value: f64,
}

impl Block for ExternalInput {
    fn type_name(&self) -> &'static str {
        "external input"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.value;
    }
    /// The value is a parameter, not a function of any input: all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn live_parameters(&self) -> &'static [&'static str] {
        &[VALUE]
    }
    fn set_live_parameter(&mut self, name: &str, value: f64) {
        if name == VALUE {
            self.value = value;
        }
    }
    /// The output is the value: ∂out/∂value = 1.
    fn live_partials(&self, name: &str, phase: Phase, _ctx: &Ctx, out: &mut [f64]) -> bool {
        if name == VALUE && phase == Phase::Signals {
            out[0] = 1.0;
        }
        name == VALUE
    }
}

/// The source of an interface input bound to signal ports, holding `start` (SI).
pub fn external_input(start: f64) -> Box<dyn Block> {
    Box::new(ExternalInput { value: start })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_the_value_last_set() {
        let gas = gas::IdealGas::air();
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &[] };
        let mut block = external_input(0.25);
        let mut out = [0.0];
        block.signal_outputs(&ctx, &mut out);
        assert_eq!(out[0], 0.25);
        block.set_live_parameter(VALUE, -3.0);
        block.rest_signal_outputs(&ctx, &mut out);
        assert_eq!(out[0], -3.0);
        assert!(!block.feedthrough() && block.states().is_empty());
    }
}

#[cfg(test)]
mod live_parameters {
    use crate::params::{ParamKind, RawValue};
    use crate::registry;

    /// A block type, the values it requires, and its live parameters.
    type Entry = (&'static str, &'static [(&'static str, f64)], &'static [&'static str]);

    /// The blocks with live parameters (docs/netlist.md lists them), built with their required values.
    const LIVE: &[Entry] = &[
        ("pressure_source", &[("p", 4e5)], &["p", "T"]),
        ("atmosphere", &[], &["p", "T"]),
        ("mass_flow_source", &[("mdot", 1e-3)], &["mdot", "T"]),
        ("piston", &[("mass", 1.0), ("stroke", 0.1)], &["external_force"]),
    ];

    #[test]
    fn live_parameters_are_declared_quantities_and_the_table_is_complete() {
        for (name, required, live) in LIVE {
            let raw: Vec<(&str, RawValue)> = required.iter().map(|(k, v)| (*k, RawValue::Number(*v))).collect();
            let block = registry::build(name, raw.iter().map(|(k, v)| (*k, v))).unwrap();
            assert_eq!(block.live_parameters(), *live, "{name}");
            let specs = registry::block_type(name).unwrap().params;
            for p in *live {
                let spec = specs.iter().find(|s| s.name == *p).unwrap_or_else(|| panic!("{name}.{p} is not declared"));
                assert!(matches!(spec.kind, ParamKind::Quantity(_)), "{name}.{p} is not a quantity");
            }
        }
        // no other block type declares live parameters (built from its own test values where it has any)
        let listed: Vec<&str> = LIVE.iter().map(|(n, _, _)| *n).collect();
        for t in crate::TYPES {
            if listed.contains(&t.name) {
                continue;
            }
            if let Ok(block) = registry::build(t.name, std::iter::empty()) {
                assert!(block.live_parameters().is_empty(), "{} declares live parameters: add it to the table", t.name);
            }
        }
    }

    #[test]
    fn setting_a_live_parameter_changes_what_the_block_does() {
        let gas = gas::IdealGas::air();
        let ctx = crate::block::Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: &[] };
        let raw = [("p", RawValue::Number(4e5))];
        let mut supply = registry::build("pressure_source", raw.iter().map(|(k, v)| (*k, v))).unwrap();
        let mut out = [gas::GasState { p: 0.0, t: 0.0, rho: 0.0, h: 0.0 }];
        supply.set_live_parameter("p", 6e5);
        supply.set_live_parameter("T", 300.0);
        supply.effort(&ctx, &mut out);
        assert_eq!((out[0].p, out[0].t), (6e5, 300.0));
        let raw = [("mass", RawValue::Number(1.0)), ("stroke", RawValue::Number(0.1))];
        let mut piston = registry::build("piston", raw.iter().map(|(k, v)| (*k, v))).unwrap();
        let mut force = [crate::block::PortForce::default()];
        let m = [crate::block::MechState::default()];
        let ctx = crate::block::Ctx { mechanical: &m, ..ctx };
        piston.forces(&ctx, &mut force);
        let before = force[0].applied;
        piston.set_live_parameter("external_force", 25.0);
        piston.forces(&ctx, &mut force);
        assert_eq!(force[0].applied - before, 25.0);
    }
}
