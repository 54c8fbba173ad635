//! `valve_delay`: the directional valve switches some time after it is
//! commanded (coil build-up and spool travel of a solenoid valve). Modelled
//! as a pure transport delay ([`blocks::delay`]) inserted between the
//! command signal and the valve's `command` input: the valve switches fully,
//! T seconds late.
//!
//! Parameter: `T` [s] in [0, 200 ms], null 0 (no block inserted).
//!
//! Least size: the response time between a limit switch's trip and the
//! valve's command (`Options::switch_latency`, 1 ms by default). On a
//! position-triggered cycle a valve delay and that response time shift the
//! valve's switching alike and cannot be told apart; the model's cycler has
//! none, so a fitted delay below it is the switch and controller's timing as
//! much as the valve's (docs/discrepancy.md, "Selection", test 5).
//!
//! Assumptions: the same delay for energising and releasing; switching
//! itself is instantaneous. (The valve block's own `switching_time`, a
//! gradual first-order spool travel, is a different effect: see
//! docs/discrepancy.md.)

use super::{check_len, Effect, EffectError, EffectParam, LeastSize, Resolution, Scale};
use crate::netlist_edit::{add_component, fresh_id, Topology};
use graph::FlatNetlist;

#[derive(Debug, Clone, Copy, Default)]
pub struct ValveDelay;

impl Effect for ValveDelay {
    fn name(&self) -> &'static str {
        "valve_delay"
    }
    fn summary(&self) -> &'static str {
        "switching delay of the directional valve (dead time after the command)"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![EffectParam {
            name: "T".into(),
            unit: "ms".into(),
            lo: 0.0,
            hi: 0.2,
            start: 0.005,
            typical: 0.02,
            null: Some(0.0),
            prior: None,
            scale: Scale::Linear,
            scan: vec![0.002, 0.005, 0.01, 0.02, 0.05],
        }]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).command.is_some()
    }
    fn least_size(&self, resolution: &Resolution) -> Vec<LeastSize> {
        if resolution.switch_latency.is_nan() || resolution.switch_latency <= 0.0 {
            return Vec::new();
        }
        vec![LeastSize {
            param: 0,
            size: resolution.switch_latency,
            why: "timing resolution of the switching instant (limit-switch and controller response, not in the model)".into(),
        }]
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let topo = Topology::of(flat);
        let (Some(valve), Some(source)) = (topo.valve, topo.command) else {
            return Err(EffectError::new(self.name(), "the directional valve has no command signal"));
        };
        let t = values[0];
        if t < 0.0 {
            return Err(EffectError::new(self.name(), format!("T = {t} s must be >= 0")));
        }
        if t == 0.0 {
            return Ok(());
        }
        let input = format!("{valve}.command");
        let id = fresh_id(flat, "valve_delay");
        flat.connections.retain(|(a, b)| !((a == &source && b == &input) || (b == &source && a == &input)));
        add_component(flat, &id, "delay", &[("delay", t)], &[]);
        flat.connections.push((source, format!("{id}.in")));
        flat.connections.push((format!("{id}.out"), input));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn the_head_pressure_rises_and_the_piston_moves_later_by_the_delay() {
        let base = meter_out();
        let mut slow = base.clone();
        ValveDelay.apply(&mut slow, &[0.03]).unwrap();
        assert_eq!(Topology::of(&slow).command.as_deref(), Some("valve_delay.out"));
        let (a, b) = (run(&base), run(&slow));
        let rise = |r: &solve::SimResult| r.series("head.p").unwrap().into_iter().find(|(_, p)| *p > 2e5).unwrap().0;
        let d = rise(&b) - rise(&a);
        assert!((d - 0.03).abs() < 2e-3, "pressure rise delayed by {d} s");
        let start = |r: &solve::SimResult| r.series("piston.x").unwrap().into_iter().find(|(_, x)| *x > 1e-3).unwrap().0;
        let d = start(&b) - start(&a);
        assert!((d - 0.03).abs() < 3e-3, "motion delayed by {d} s");
    }
}
