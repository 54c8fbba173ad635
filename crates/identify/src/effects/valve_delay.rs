//! `valve_delay`: the directional valve does not switch instantly. Uses the
//! valve block's spool model: the spool position follows the command with a
//! first-order lag of time constant T/3, reaching 95 % of its travel after T
//! (the "switching time" of valve data sheets), and every path's flow scales
//! with its opening.
//!
//! Parameter: `T` [s] in [0, 200 ms], null 0 (instant switching). It is added
//! to any switching time the netlist already has.
//!
//! Assumption: the same switching time in both directions (energise and
//! release); no pure dead time before the spool starts moving.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{param_si, set_param_si, Topology};
use graph::FlatNetlist;

#[derive(Debug, Clone, Copy, Default)]
pub struct ValveDelay;

impl Effect for ValveDelay {
    fn name(&self) -> &'static str {
        "valve_delay"
    }
    fn summary(&self) -> &'static str {
        "switching delay of the directional valve (spool travel time)"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![EffectParam { name: "T", unit: "ms", lo: 0.0, hi: 0.2, start: 0.005, typical: 0.02, null: Some(0.0), scale: Scale::Linear }]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).valve.is_some()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let valve = Topology::of(flat).valve.ok_or_else(|| EffectError::new(self.name(), "the circuit has no directional valve"))?;
        let t = values[0];
        if t < 0.0 {
            return Err(EffectError::new(self.name(), format!("T = {t} s must be >= 0")));
        }
        if t == 0.0 {
            return Ok(());
        }
        let old = param_si(flat, &valve, "switching_time").map_err(|e| EffectError::new(self.name(), e))?;
        set_param_si(flat, &valve, "switching_time", old + t).map_err(|e| EffectError::new(self.name(), e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn a_slow_spool_delays_the_head_pressure_rise() {
        let base = meter_out();
        let mut slow = base.clone();
        ValveDelay.apply(&mut slow, &[0.03]).unwrap();
        assert_eq!(param_si(&slow, "dcv", "switching_time").unwrap(), 0.03);
        ValveDelay.apply(&mut slow, &[0.01]).unwrap();
        assert!((param_si(&slow, "dcv", "switching_time").unwrap() - 0.04).abs() < 1e-15);
        let (a, b) = (run(&base), run(&slow));
        let at = |r: &solve::SimResult, t: f64| r.series("head.p").unwrap().into_iter().find(|(u, _)| *u >= t).unwrap().1;
        // after 5 ms the instant valve has already filled much of the head chamber
        assert!(at(&b, 0.005) < at(&a, 0.005) - 2e4, "{} vs {}", at(&b, 0.005), at(&a, 0.005));
    }
}
