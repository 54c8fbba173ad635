//! `supply_droop`: the supply is not an infinite reservoir. A supply line of
//! sonic conductance C_line (ISO 6358, Eq. 33–35) and volume V_line is
//! inserted between the pressure source and everything it fed, so the valve
//! inlet pressure dips while the cylinder draws air and recovers with time
//! constant ≈ V_line/(γ·C_line·p_N)·… (paper Eq. 19). The paper notes a 5 %
//! supply dip at the start of motion in its experiments (§2.1).
//!
//! Parameters: `C_line` [m³/(s·Pa)] in [20, 20 000 L/(min·bar)], log scale,
//! "null" at the upper bound (a line 40 times the valve's conductance drops
//! less than 0.1 % of the pressure); `V_line` [m³] in [0.01 L, 10 L], log
//! scale, a shape parameter.
//!
//! Assumptions: the line volume is a rigid tank at the supply temperature
//! with τ_T = 1 s (a hose is close to isothermal); it starts at the supply
//! pressure.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{add_component, fresh_id, param_si, Topology};
use graph::FlatNetlist;

const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

#[derive(Debug, Clone, Copy, Default)]
pub struct SupplyDroop;

impl Effect for SupplyDroop {
    fn name(&self) -> &'static str {
        "supply_droop"
    }
    fn summary(&self) -> &'static str {
        "finite supply line: a conductance and a volume between source and valve"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![
            EffectParam {
                name: "C_line".into(),
                unit: "L/min/bar".into(),
                lo: 20.0 * L_MIN_BAR,
                hi: 20_000.0 * L_MIN_BAR,
                start: 300.0 * L_MIN_BAR,
                typical: 300.0 * L_MIN_BAR,
                null: Some(20_000.0 * L_MIN_BAR),
                prior: None,
                scale: Scale::Log,
                scan: vec![1000.0 * L_MIN_BAR, 300.0 * L_MIN_BAR, 100.0 * L_MIN_BAR, 40.0 * L_MIN_BAR],
            },
            EffectParam {
                name: "V_line".into(),
                unit: "L".into(),
                lo: 1e-5,
                hi: 1e-2,
                start: 3e-4,
                typical: 3e-4,
                null: None,
                prior: None,
                scale: Scale::Log,
                scan: vec![5e-5, 5e-4, 3e-3],
            },
        ]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).supply.is_some()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let supply =
            Topology::of(flat).supply.ok_or_else(|| EffectError::new(self.name(), "no pressure source feeds the directional valve"))?;
        let (c, v) = (values[0], values[1]);
        if c <= 0.0 || v <= 0.0 {
            return Err(EffectError::new(self.name(), format!("C_line {c} and V_line {v} must be > 0")));
        }
        let p = param_si(flat, &supply, "p").map_err(|e| EffectError::new(self.name(), e))?;
        let t = param_si(flat, &supply, "T").map_err(|e| EffectError::new(self.name(), e))?;
        let line = fresh_id(flat, "supply_line");
        let restriction = fresh_id(flat, "supply_restriction");
        let source_port = format!("{supply}.port");
        // everything that was wired to the source now hangs on the line volume
        for (a, b) in flat.connections.iter_mut() {
            if *a == source_port {
                *a = format!("{line}.port");
            }
            if *b == source_port {
                *b = format!("{line}.port");
            }
        }
        add_component(flat, &line, "chamber", &[("dead_volume", v), ("tau_thermal", 1.0), ("T_wall", t)], &[("p0", p), ("T0", t)]);
        add_component(flat, &restriction, "conductance", &[("C", c), ("b", 0.3)], &[]);
        flat.connections.push((source_port, format!("{restriction}.a")));
        flat.connections.push((format!("{restriction}.b"), format!("{line}.port")));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{meter_out, run};

    #[test]
    fn the_valve_inlet_pressure_dips_when_the_cylinder_fills() {
        let base = meter_out();
        let mut weak = base.clone();
        SupplyDroop.apply(&mut weak, &[60.0 * L_MIN_BAR, 2e-4]).unwrap();
        let r = run(&weak);
        let line = r.series("supply_line.p").unwrap();
        let min = line.iter().map(|(_, p)| *p).fold(f64::INFINITY, f64::min);
        assert!(min < 0.97 * 4e5, "the line pressure must dip by more than 3 %: {min}");
        assert!((line[0].1 - 4e5).abs() < 1.0, "starts at the supply pressure");
        // and the stroke is slower than with the ideal source
        let x = |r: &solve::SimResult| r.series("piston.x").unwrap().last().unwrap().1;
        assert!(x(&r) < x(&run(&base)));
    }
}
