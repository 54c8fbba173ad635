//! `piston_seal_leak`: air passing the piston seal from one chamber to the
//! other, modelled as an ISO 6358 restriction (paper Eq. 33–35) between the
//! head-side and rod-side chamber ports.
//!
//! Parameter: `C` [m³/(s·Pa)], the sonic conductance of the leak path, in
//! [0, 5 L/(min·bar)]; null 0 (no component added). The critical ratio is
//! fixed at b = 0.5 (a narrow annular gap: its exact value is not
//! identifiable next to C from cylinder data).
//!
//! Assumptions: the leak is a quasi-steady restriction with no volume of its
//! own; flow runs from the higher to the lower chamber pressure and carries
//! the upstream enthalpy.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{add_component, fresh_id, Topology};
use graph::FlatNetlist;

/// 1 L/(min·bar) in m³/(s·Pa).
const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

#[derive(Debug, Clone, Copy, Default)]
pub struct PistonSealLeak;

impl Effect for PistonSealLeak {
    fn name(&self) -> &'static str {
        "piston_seal_leak"
    }
    fn summary(&self) -> &'static str {
        "leak across the piston seal: a conductance between the two chambers"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![EffectParam {
            name: "C",
            unit: "L/min/bar",
            lo: 0.0,
            hi: 5.0 * L_MIN_BAR,
            start: 0.2 * L_MIN_BAR,
            typical: 0.5 * L_MIN_BAR,
            null: Some(0.0),
            scale: Scale::Linear,
        }]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).chambers().is_ok()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let topo = Topology::of(flat);
        let (head, rod) = topo.chambers().map_err(|e| EffectError::new(self.name(), e))?;
        let c = values[0];
        if c < 0.0 {
            return Err(EffectError::new(self.name(), format!("C = {c} must be >= 0")));
        }
        if c == 0.0 {
            return Ok(());
        }
        let id = fresh_id(flat, "seal_leak");
        let (head_port, rod_port) = (format!("{head}.port"), format!("{rod}.port"));
        add_component(flat, &id, "conductance", &[("C", c), ("b", 0.5)], &[]);
        flat.connections.push((head_port, format!("{id}.a")));
        flat.connections.push((format!("{id}.b"), rod_port));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn a_leak_feeds_the_rod_chamber_while_the_head_is_pressurised() {
        // With the head at supply pressure and the piston moving, a leak into
        // the rod side raises the rod pressure, which slows the stroke.
        let base = meter_out();
        let mut leaky = base.clone();
        PistonSealLeak.apply(&mut leaky, &[2.0 * L_MIN_BAR]).unwrap();
        assert!(leaky.components.iter().any(|c| c.kind == "conductance"));
        let (a, b) = (run(&base), run(&leaky));
        let x = |r: &solve::SimResult| r.series("piston.x").unwrap().last().unwrap().1;
        let p2 = |r: &solve::SimResult| r.series("rod.p").unwrap().last().unwrap().1;
        assert!(x(&b) < x(&a), "stroke must be slower: {} vs {}", x(&b), x(&a));
        assert!(p2(&b) > p2(&a), "rod pressure must be higher: {} vs {}", p2(&b), p2(&a));
        // C = 0 adds nothing
        let mut same = base.clone();
        PistonSealLeak.apply(&mut same, &[0.0]).unwrap();
        assert_eq!(same, base);
        assert!(PistonSealLeak.apply(&mut same, &[-1.0]).is_err());
    }
}
