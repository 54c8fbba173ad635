//! `heat_transfer`: wall heat exchange in a model whose chambers are
//! adiabatic (τ_T = ∞). Paper Eq. 8: Q_w = m·c_v·(T_w − T)/τ_T, one thermal
//! time constant for all the cylinder's chambers.
//!
//! Parameter: `rate` = 1/τ_T [1/s] in [0, 50 1/s], null 0 (adiabatic). Fitted
//! as a rate so that "no heat exchange" is a finite point.
//!
//! Applies when at least one chamber of the netlist has τ_T = ∞; only those
//! chambers are changed.

use super::{check_len, Effect, EffectError, EffectParam, Scale};
use crate::netlist_edit::{param_si, set_param_si};
use graph::FlatNetlist;

#[derive(Debug, Clone, Copy, Default)]
pub struct HeatTransfer;

fn adiabatic_chambers(flat: &FlatNetlist) -> Vec<String> {
    flat.components
        .iter()
        .filter(|c| c.kind == "chamber")
        .filter(|c| param_si(flat, &c.id, "tau_thermal").map(|t| t.is_infinite()).unwrap_or(false))
        .map(|c| c.id.clone())
        .collect()
}

impl Effect for HeatTransfer {
    fn name(&self) -> &'static str {
        "heat_transfer"
    }
    fn summary(&self) -> &'static str {
        "wall heat exchange with a thermal time constant (Eq. 8) in adiabatic chambers"
    }
    fn params(&self) -> Vec<EffectParam> {
        vec![EffectParam {
            name: "rate".into(),
            unit: "1/s".into(),
            lo: 0.0,
            hi: 50.0,
            start: 0.3,
            typical: 1.0,
            null: Some(0.0),
            prior: None,
            scale: Scale::Linear,
            scan: vec![0.1, 0.3, 1.0, 3.0, 10.0],
        }]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        !adiabatic_chambers(flat).is_empty()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let rate = values[0];
        if rate < 0.0 {
            return Err(EffectError::new(self.name(), format!("rate {rate} must be >= 0")));
        }
        if rate == 0.0 {
            return Ok(());
        }
        for id in adiabatic_chambers(flat) {
            set_param_si(flat, &id, "tau_thermal", 1.0 / rate).map_err(|e| EffectError::new(self.name(), e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::tests::{max_diff, meter_out, run};

    #[test]
    fn turns_adiabatic_chambers_into_exchanging_ones_and_null_changes_nothing() {
        let mut adiabatic = meter_out();
        for id in ["head", "rod"] {
            set_param_si(&mut adiabatic, id, "tau_thermal", f64::INFINITY).unwrap();
        }
        assert!(HeatTransfer.applies_to(&adiabatic));
        let mut same = adiabatic.clone();
        HeatTransfer.apply(&mut same, &[0.0]).unwrap();
        assert_eq!(same, adiabatic);
        let mut warm = adiabatic.clone();
        HeatTransfer.apply(&mut warm, &[0.2]).unwrap();
        assert!((param_si(&warm, "head", "tau_thermal").unwrap() - 5.0).abs() < 1e-12);
        // τ = 5 s reproduces the original meter-out netlist exactly
        let orig = meter_out();
        assert!(max_diff(&run(&orig), &run(&warm), "head.p") < 1e-6);
        // and differs from the adiabatic one
        assert!(max_diff(&run(&adiabatic), &run(&warm), "head.T") > 0.1);
    }
}
