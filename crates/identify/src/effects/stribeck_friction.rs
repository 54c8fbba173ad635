//! `stribeck_friction`: seal friction that breaks away above the Coulomb
//! level and decays to it with speed (Stribeck curve), on top of the paper's
//! Eq. 37. Uses the friction block's `breakaway_ratio` r and
//! `stribeck_velocity` v_s: F = F_c + (r − 1)·F_c·exp(−(v/v_s)²) + c·|v|.
//!
//! Parameters: `breakaway_ratio` [-] in [1, 5], null 1; `stribeck_velocity`
//! [m/s] in [1 mm/s, 300 mm/s] (a shape parameter: it has no effect when the
//! ratio is 1, so it has no null of its own; fitted in log scale).
//!
//! Applies when the netlist's friction has no breakaway above Coulomb yet
//! (ratio 1).

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{param_si, set_param_si, Topology};
use graph::FlatNetlist;

#[derive(Debug, Clone, Copy, Default)]
pub struct StribeckFriction;

impl Effect for StribeckFriction {
    fn name(&self) -> &'static str {
        "stribeck_friction"
    }
    fn summary(&self) -> &'static str {
        "breakaway friction above the Coulomb level, decaying with speed (Stribeck)"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![
            EffectParam {
                name: "breakaway_ratio".into(),
                unit: "".into(),
                lo: 1.0,
                hi: 5.0,
                start: 1.3,
                typical: 1.0,
                null: Some(1.0),
                prior: None,
                scale: Scale::Linear,
                scan: vec![1.5, 2.0, 3.0, 4.0],
            },
            EffectParam {
                name: "stribeck_velocity".into(),
                unit: "mm/s".into(),
                lo: 1e-3,
                hi: 0.3,
                start: 0.02,
                typical: 0.02,
                null: None,
                prior: None,
                scale: Scale::Log,
                scan: vec![0.005, 0.02, 0.08],
            },
        ]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        match Topology::of(flat).friction {
            Some(f) => param_si(flat, &f, "breakaway_ratio").map(|r| r == 1.0).unwrap_or(false),
            None => false,
        }
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let f = Topology::of(flat).friction.ok_or_else(|| EffectError::new(self.name(), "the circuit has no friction block"))?;
        let (ratio, vs) = (values[0], values[1]);
        if !(1.0..=10.0).contains(&ratio) || vs <= 0.0 {
            return Err(EffectError::new(
                self.name(),
                format!("breakaway_ratio {ratio} must be in [1, 10] and stribeck_velocity {vs} > 0"),
            ));
        }
        if ratio == 1.0 {
            return Ok(());
        }
        set_param_si(flat, &f, "breakaway_ratio", ratio).map_err(|e| EffectError::new(self.name(), e))?;
        set_param_si(flat, &f, "stribeck_velocity", vs).map_err(|e| EffectError::new(self.name(), e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn a_higher_breakaway_delays_the_start_of_motion() {
        let base = meter_out();
        let mut sticky = base.clone();
        StribeckFriction.apply(&mut sticky, &[3.0, 0.01]).unwrap();
        assert_eq!(param_si(&sticky, "friction", "breakaway_ratio").unwrap(), 3.0);
        assert!(!StribeckFriction.applies_to(&sticky), "already modelled");
        let (a, b) = (run(&base), run(&sticky));
        let start = |r: &solve::SimResult| r.series("piston.x").unwrap().into_iter().find(|(_, x)| *x > 1e-4).unwrap().0;
        assert!(start(&b) > start(&a), "{} vs {}", start(&b), start(&a));
    }
}
