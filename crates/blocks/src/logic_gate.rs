//! Logic gate on on/off signals: AND, OR, XOR, NAND, NOR, NOT.
//!
//! # Ports
//! - `in1`, `in2` [1] — signal inputs (`not` has `in1` only): on above
//!   0.55, off below 0.45 (hysteresis around 0.5).
//! - `out` [1] — signal output: 1 or 0.
//!
//! # Parameters
//! - `operation` [`and`]: `and`, `or`, `xor`, `nand`, `nor` or `not`.
//!
//! # Behaviour
//! Boolean algebra on the inputs' on/off states. Each input's state is
//! discrete and changes at an event (its root function is negative while
//! the state stands, see [`crate::support::switch_root`]), so the output
//! switches exactly when an input crosses its threshold and a slowly
//! varying input cannot make it chatter. At rest the output is computed
//! from the inputs directly.

use crate::block::*;
use crate::params::{ParamSpec, Params};
use crate::support::{switch_root, switch_state};

pub const PARAMS: &[ParamSpec] =
    &[ParamSpec::choice("operation", &["and", "or", "xor", "nand", "nor", "not"], 0, "boolean function of the inputs")];
pub const PORTS: &[PortSpec] = &[
    PortSpec::signal("in1", PortKind::SignalIn, "1", "input 1"),
    PortSpec::signal("in2", PortKind::SignalIn, "1", "input 2 (not for `not`)"),
    PortSpec::signal("out", PortKind::SignalOut, "1", "1 = true, 0 = false"),
];
const PORTS_NOT: &[PortSpec] =
    &[PortSpec::signal("in1", PortKind::SignalIn, "1", "input"), PortSpec::signal("out", PortKind::SignalOut, "1", "1 = true, 0 = false")];

/// The boolean functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operation {
    And,
    Or,
    Xor,
    Nand,
    Nor,
    Not,
}

impl Operation {
    pub fn apply(self, a: bool, b: bool) -> bool {
        match self {
            Operation::And => a && b,
            Operation::Or => a || b,
            Operation::Xor => a != b,
            Operation::Nand => !(a && b),
            Operation::Nor => !(a || b),
            Operation::Not => !a,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct LogicGate {
    pub operation: Operation,
    /// Accepted on/off state of each input.
    pub inputs: [bool; 2],
}

impl LogicGate {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let operation = [Operation::And, Operation::Or, Operation::Xor, Operation::Nand, Operation::Nor, Operation::Not][p.choice("operation")];
        Ok(LogicGate { operation, inputs: [false, false] })
    }
    fn arity(&self) -> usize {
        if self.operation == Operation::Not {
            1
        } else {
            2
        }
    }
    fn value(&self, a: bool, b: bool) -> f64 {
        if self.operation.apply(a, b) {
            1.0
        } else {
            0.0
        }
    }
}

impl Block for LogicGate {
    fn type_name(&self) -> &'static str {
        "logic_gate"
    }
    fn ports(&self) -> &[PortSpec] {
        if self.arity() == 1 {
            PORTS_NOT
        } else {
            PORTS
        }
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.value(self.inputs[0], self.inputs[1]);
    }
    fn rest_signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        let b = ctx.signals.get(1).is_some_and(|&u| u > 0.5);
        out[0] = self.value(ctx.signals[0] > 0.5, b);
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        vec![(self.arity(), Fact::CommandLevels(vec![0.0, 1.0]))]
    }
    fn n_event_functions(&self) -> usize {
        self.arity()
    }
    fn event_functions(&self, ctx: &Ctx, out: &mut [f64]) {
        for (k, g) in out.iter_mut().enumerate() {
            *g = switch_root(self.inputs[k], ctx.signals[k]);
        }
    }
    fn on_event(&mut self, _event: EventKind, ctx: &Ctx) -> EventOutcome {
        for k in 0..self.arity() {
            self.inputs[k] = switch_state(self.inputs[k], ctx.signals[k]);
        }
        EventOutcome::default()
    }
}

/// Registry entry of `logic_gate`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "logic_gate",
    family: crate::registry::Family::Control,
    doc: "AND, OR, XOR, NAND, NOR or NOT of on/off signals",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(LogicGate::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_tables() {
        let table = |op: Operation| [(false, false), (false, true), (true, false), (true, true)].map(|(a, b)| op.apply(a, b));
        assert_eq!(table(Operation::And), [false, false, false, true]);
        assert_eq!(table(Operation::Or), [false, true, true, true]);
        assert_eq!(table(Operation::Xor), [false, true, true, false]);
        assert_eq!(table(Operation::Nand), [true, true, true, false]);
        assert_eq!(table(Operation::Nor), [true, false, false, false]);
        assert_eq!(table(Operation::Not), [true, true, false, false]);
    }

    #[test]
    fn output_changes_at_the_input_event() {
        let gas = gas::IdealGas::air();
        let mut g = LogicGate { operation: Operation::And, inputs: [false, false] };
        let ctx = |u: &'static [f64]| Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[], mechanical: &[], signals: u };
        let mut r = [0.0; 2];
        g.event_functions(&ctx(&[1.0, 1.0]), &mut r);
        assert!(r.iter().all(|&x| x > 0.0));
        g.on_event(EventKind::Crossing(0), &ctx(&[1.0, 1.0]));
        let mut out = [0.0];
        g.signal_outputs(&ctx(&[1.0, 1.0]), &mut out);
        assert_eq!(out[0], 1.0);
        g.event_functions(&ctx(&[1.0, 1.0]), &mut r);
        assert!(r.iter().all(|&x| x < 0.0));
        // 0.5 is inside the hysteresis band: no event, the state holds
        g.event_functions(&ctx(&[0.5, 1.0]), &mut r);
        assert!(r[0] < 0.0);
    }
}
