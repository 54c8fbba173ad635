//! `dead_volume`: volume the model misses in either chamber (ports, fittings,
//! the tube between valve and cylinder), added to each chamber's
//! `dead_volume` (paper Eq. 6: V = V_dead + A·(l₀ + σx)).
//!
//! Parameters: `extra_head`, `extra_rod` [m³], each in [0, 200 cm³], null 0.
//! The effect counts as present when at least one of them is clearly away
//! from zero.
//!
//! Assumption: the extra volume is at the chamber's pressure and temperature
//! (lumped with it); tube resistance is not part of this effect.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{param_si, set_param_si, Topology};
use graph::FlatNetlist;

#[derive(Debug, Clone, Copy, Default)]
pub struct DeadVolume;

fn param(name: &str) -> EffectParam {
    EffectParam {
        name: name.into(),
        unit: "cm3".into(),
        lo: 0.0,
        hi: 200e-6,
        start: 5e-6,
        typical: 20e-6,
        null: Some(0.0),
        prior: None,
        scale: Scale::Linear,
        scan: vec![0.0, 10e-6, 40e-6],
    }
}

impl Effect for DeadVolume {
    fn name(&self) -> &'static str {
        "dead_volume"
    }
    fn summary(&self) -> &'static str {
        "extra (dead) volume in the head-side and/or rod-side chamber"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![param("extra_head"), param("extra_rod")]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).chambers().is_ok()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let topo = Topology::of(flat);
        let (head, rod) = topo.chambers().map_err(|e| EffectError::new(self.name(), e))?;
        let (head, rod) = (head.to_string(), rod.to_string());
        for (id, extra) in [(head, values[0]), (rod, values[1])] {
            if extra < 0.0 {
                return Err(EffectError::new(self.name(), format!("extra volume {extra} must be >= 0")));
            }
            if extra == 0.0 {
                continue;
            }
            let v = param_si(flat, &id, "dead_volume").map_err(|e| EffectError::new(self.name(), e))?;
            set_param_si(flat, &id, "dead_volume", v + extra).map_err(|e| EffectError::new(self.name(), e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn adds_to_the_written_dead_volume_and_slows_the_head_pressure_rise() {
        let base = meter_out();
        let mut more = base.clone();
        DeadVolume.apply(&mut more, &[30e-6, 10e-6]).unwrap();
        assert!((param_si(&more, "head", "dead_volume").unwrap() - 50e-6).abs() < 1e-15);
        assert!((param_si(&more, "rod", "dead_volume").unwrap() - 30e-6).abs() < 1e-15);
        // larger capacity on the head side: lower head pressure 2 ms after the switch
        let (a, b) = (run(&base), run(&more));
        let at = |r: &solve::SimResult, t: f64| r.series("head.p").unwrap().into_iter().find(|(u, _)| *u >= t).unwrap().1;
        assert!(at(&b, 0.002) < at(&a, 0.002) - 1e4, "{} vs {}", at(&b, 0.002), at(&a, 0.002));
    }
}
