//! Schedule: a time-table controller for valve commands.
//!
//! # Ports
//! - `command` — signal output: the value of the last switching instant
//!   reached (e.g. 1 = actuate, 0 = release).
//!
//! # Parameters
//! - `times` [s, list, required]: switching instants, increasing.
//! - `values` [-, list, required]: command after each instant (same length).
//! - `initial` [-, 0]: command before the first instant.
//!
//! # Behaviour
//! Piecewise-constant output; each instant is a time event, so the solver
//! restarts exactly at the switch.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::list("times", dim::TIME, Range::NonNegative, "s", "switching instants"),
    ParamSpec::list("values", dim::DIMENSIONLESS, Range::Any, "", "command after each instant"),
    ParamSpec::quantity("initial", dim::DIMENSIONLESS, Some(0.0), Range::Any, "", "command before the first instant"),
];
pub const PORTS: &[PortSpec] = &[PortSpec::signal("command", PortKind::SignalOut, "1", "command value")];

#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    pub times: Vec<f64>,
    pub values: Vec<f64>,
    pub initial: f64,
}

impl Schedule {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let times = p.list("times").to_vec();
        let values = p.list("values").to_vec();
        if times.is_empty() {
            return Err(crate::BlockError::invalid("times", "needs at least one instant"));
        }
        if times.len() != values.len() {
            return Err(crate::BlockError::invalid("values", &format!("has {} entries but times has {}", values.len(), times.len())));
        }
        if times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(crate::BlockError::invalid("times", "must be strictly increasing"));
        }
        Ok(Schedule { times, values, initial: p.get("initial") })
    }
    /// Command at time t (the value switched at an instant applies from that instant on).
    pub fn value(&self, t: f64) -> f64 {
        match self.times.iter().rposition(|&ti| ti <= t) {
            Some(i) => self.values[i],
            None => self.initial,
        }
    }
}

impl Block for Schedule {
    fn type_name(&self) -> &'static str {
        "schedule"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    /// Every output is piecewise constant in the continuous states (it
    /// changes only at events): all partials are zero.
    fn partials(&self, _phase: Phase, _ctx: &Ctx, _b: &Balances, _d: &mut Partials) -> bool {
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.value(ctx.t);
    }
    /// Before t = 0 the schedule holds its `initial` value.
    fn rest_signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.initial;
    }
    fn facts(&self) -> Vec<(usize, Fact)> {
        let mut levels = self.values.clone();
        levels.push(self.initial);
        vec![(0, Fact::CommandLevels(levels))]
    }
    fn next_time_event(&self, t: f64) -> Option<f64> {
        self.times.iter().copied().find(|&ti| ti > t)
    }
}

/// Registry entry of `schedule`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "schedule",
    family: crate::registry::Family::Control,
    doc: "time-table command signal",
    params: PARAMS,
    ports: PORTS,
    outputs: &[],
    build: |p| crate::registry::boxed(Schedule::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::RawValue;

    #[test]
    fn steps_at_its_instants() {
        let raw = [
            ("times", RawValue::Text("0.5 s, 1500 ms".into())),
            ("values", RawValue::List(vec![RawValue::Number(1.0), RawValue::Number(0.0)])),
        ];
        let s = Schedule::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).unwrap();
        assert_eq!(s.value(0.0), 0.0);
        assert_eq!(s.value(0.5), 1.0);
        assert_eq!(s.value(1.49), 1.0);
        assert_eq!(s.value(1.5), 0.0);
        assert_eq!(s.next_time_event(0.0), Some(0.5));
        assert_eq!(s.next_time_event(0.5), Some(1.5));
        assert_eq!(s.next_time_event(1.5), None);
    }

    #[test]
    fn rejects_unsorted_or_mismatched_lists() {
        let raw = [("times", RawValue::Text("1, 0.5".into())), ("values", RawValue::Text("1, 0".into()))];
        assert!(Schedule::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).is_err());
        let raw = [("times", RawValue::Text("1".into())), ("values", RawValue::Text("1, 0".into()))];
        assert!(Schedule::from_params(&Params::from_raw(PARAMS, raw.iter().map(|(k, v)| (*k, v))).unwrap()).is_err());
    }
}
