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
            scan: &[0.03 * L_MIN_BAR, 0.1 * L_MIN_BAR, 0.3 * L_MIN_BAR, 1.0 * L_MIN_BAR, 3.0 * L_MIN_BAR],
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
    fn a_leak_speeds_up_the_meter_out_stroke() {
        // Meter-out extend stroke: force balance puts the rod-side pressure
        // above the head side (p₂ ≈ p₁·A₁/A₂ with A₁/A₂ = 1.125), so the leak
        // drains the rod chamber towards the head and, with the throttle,
        // lets the piston move faster: ρ₂A₂v = ṁ_throttle + ṁ_leak.
        let base = meter_out();
        let mut leaky = base.clone();
        PistonSealLeak.apply(&mut leaky, &[2.0 * L_MIN_BAR]).unwrap();
        assert!(leaky.components.iter().any(|c| c.kind == "conductance"));
        let (a, b) = (run(&base), run(&leaky));
        let mean_v = |r: &solve::SimResult| {
            let v: Vec<f64> = r.series("piston.v").unwrap().into_iter().filter(|(t, _)| (0.9..1.2).contains(t)).map(|(_, v)| v).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let last = |r: &solve::SimResult, c: &str| r.series(c).unwrap().last().unwrap().1;
        assert!(last(&a, "rod.p") > last(&a, "head.p"), "rod side above head side");
        assert!(mean_v(&b) > 1.02 * mean_v(&a), "speed {} vs {}", mean_v(&b), mean_v(&a));
        // C = 0 adds nothing
        let mut same = base.clone();
        PistonSealLeak.apply(&mut same, &[0.0]).unwrap();
        assert_eq!(same, base);
        assert!(PistonSealLeak.apply(&mut same, &[-1.0]).is_err());
    }
}
