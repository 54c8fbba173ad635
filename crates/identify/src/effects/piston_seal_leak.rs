//! `piston_seal_leak`: air passing the piston seal from one chamber to the
//! other, between the head-side and rod-side chamber ports.
//!
//! A seal gap may behave like an orifice, like a long narrow passage or
//! like the linear leak of the textbooks, and cylinder data cannot be
//! expected to come from any law exactly, so the leak is one family of one
//! size C that spans the three laws met in practice:
//! - an ISO 6358 orifice (paper Eq. 33–35, `conductance` block), critical
//!   ratio b = 0.5 (a narrow annular gap; b is not identifiable next to C
//!   from cylinder data): chokes, grows with the upstream pressure;
//! - a compressible laminar capillary (`capillary` block, Hagen–Poiseuille,
//!   ṁ ∝ p_u² − p_d²): never chokes, grows with the mean pressure;
//! - a flow linear in the pressure difference, ṁ ∝ p_u − p_d, the internal
//!   leakage law of most pneumatics textbooks (P. Beater, "Pneumatic
//!   Drives", Springer 2007; E. Richer & Y. Hurmuzlu, J. Dyn. Sys. Meas.
//!   Control 122 (2000) 416): an incompressible laminar gap. It is built
//!   from the `conductance` block with its laminar region over the whole
//!   range (b = 0.001, b_lam = 0.002; ISO 6358-1:2013 makes the flow
//!   linear in p₁ − p₂ above b_lam).
//!
//! Each law is scaled to pass the flow of an ISO orifice of conductance C
//! from 6 bar to 5 bar at 293.15 K, so that C reads as the leak's size
//! whatever its law. The shape `law` λ ∈ [0, 2] blends neighbours: λ ∈
//! [0, 1] is (1 − λ)·orifice + λ·capillary, λ ∈ [1, 2] is
//! (2 − λ)·capillary + (λ − 1)·linear. The null model (C = 0) lies inside
//! the family for every λ.
//!
//! Parameters: `C` [m³/(s·Pa)] in [0, 5 L/(min·bar)], null 0 (nothing
//! added); `law` λ in [0, 2], a shape parameter scanned at 0, 1 and 2 (one
//! start per law, [`crate::candidates`]).
//!
//! Assumptions: quasi-steady flow with no volume of its own; flow runs from
//! the higher to the lower chamber pressure and carries the upstream
//! enthalpy.

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
        vec![
            EffectParam {
                name: "C".into(),
                unit: "L/min/bar".into(),
                lo: 0.0,
                hi: 5.0 * L_MIN_BAR,
                start: 0.2 * L_MIN_BAR,
                typical: 0.5 * L_MIN_BAR,
                null: Some(0.0),
                prior: None,
                scale: Scale::Linear,
                scan: vec![0.03 * L_MIN_BAR, 0.1 * L_MIN_BAR, 0.3 * L_MIN_BAR, 1.0 * L_MIN_BAR, 3.0 * L_MIN_BAR],
            },
            EffectParam {
                name: "law".into(),
                unit: "".into(),
                lo: 0.0,
                hi: 2.0,
                start: 0.0,
                typical: 1.0,
                null: None,
                prior: None,
                scale: Scale::Linear,
                scan: vec![0.0, 1.0, 2.0],
            },
        ]
    }
    fn applies_to(&self, flat: &FlatNetlist) -> bool {
        Topology::of(flat).chambers().is_ok()
    }
    fn apply(&self, flat: &mut FlatNetlist, values: &[f64]) -> Result<(), EffectError> {
        check_len(self, values)?;
        let topo = Topology::of(flat);
        let (head, rod) = topo.chambers().map_err(|e| EffectError::new(self.name(), e))?;
        let (c, law) = (values[0], values[1]);
        if c < 0.0 {
            return Err(EffectError::new(self.name(), format!("C = {c} must be >= 0")));
        }
        if !(0.0..=2.0).contains(&law) {
            return Err(EffectError::new(self.name(), format!("law = {law} must be in [0, 2]")));
        }
        if c == 0.0 {
            return Ok(());
        }
        let (head_port, rod_port) = (format!("{head}.port"), format!("{rod}.port"));
        let (orifice, capillary, linear) = shares(law);
        let mut paths = Vec::new();
        if orifice > 0.0 {
            paths.push(("conductance", vec![("C", orifice * c), ("b", ISO_B)]));
        }
        if capillary > 0.0 {
            paths.push(("capillary", vec![("k", capillary_equivalent() * capillary * c)]));
        }
        if linear > 0.0 {
            paths.push(("conductance", vec![("C", linear_equivalent() * linear * c), ("b", LINEAR_B), ("b_lam", LINEAR_B_LAM)]));
        }
        for (kind, params) in paths {
            let id = fresh_id(flat, "seal_leak");
            add_component(flat, &id, kind, &params, &[]);
            flat.connections.push((head_port.clone(), format!("{id}.a")));
            flat.connections.push((format!("{id}.b"), rod_port.clone()));
        }
        Ok(())
    }
}

/// Critical pressure ratio of the orifice part.
const ISO_B: f64 = 0.5;
/// Critical and laminar ratios of the linear part: laminar (ṁ ∝ p₁ − p₂)
/// for every pressure ratio above 0.002.
const LINEAR_B: f64 = 0.001;
const LINEAR_B_LAM: f64 = 0.002;

/// Shares (orifice, capillary, linear) of the law λ ∈ [0, 2].
fn shares(law: f64) -> (f64, f64, f64) {
    if law <= 1.0 {
        (1.0 - law, law, 0.0)
    } else {
        (0.0, 2.0 - law, law - 1.0)
    }
}

/// The conductance C_lin, per unit of ISO conductance, of the linear part:
/// in its laminar region ṁ = C_lin·ρ_ref·K_T·ω(b_lam)/(1 − b_lam)·(p_u − p_d)
/// (ISO 6358-1:2013), equal to the b = 0.5 orifice's flow from 6 to 5 bar.
fn linear_equivalent() -> f64 {
    let (p_u, p_d) = (6e5, 5e5);
    let x = (p_d / p_u - ISO_B) / (1.0 - ISO_B);
    let iso = p_u * (1.0 - x * x).sqrt();
    let q = (LINEAR_B_LAM - LINEAR_B) / (1.0 - LINEAR_B);
    let omega_lam = (1.0 - q * q).sqrt();
    iso * (1.0 - LINEAR_B_LAM) / (omega_lam * (p_u - p_d))
}

/// κ: the capillary coefficient per unit of ISO conductance that passes the
/// same mass flow from 6 bar to 5 bar at 293.15 K. The ISO flow there is
/// C·ρ_ref·p_u·√(1 − ((r − b)/(1 − b))²) (Eq. 34 with r = 5/6 and T at the
/// reference, ρ_ref = 1.185 kg/m³ as in the `conductance` block), the
/// capillary's k·(p_u² − p_d²)/(2 R T) with R of air.
fn capillary_equivalent() -> f64 {
    let (p_u, p_d) = (6e5, 5e5);
    let (rho_n, t_n, r_air) = (1.185, 293.15, 287.05);
    let x = (p_d / p_u - ISO_B) / (1.0 - ISO_B);
    let iso = rho_n * p_u * (1.0 - x * x).sqrt();
    let capillary = (p_u * p_u - p_d * p_d) / (2.0 * r_air * t_n);
    iso / capillary
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
        PistonSealLeak.apply(&mut leaky, &[2.0 * L_MIN_BAR, 0.0]).unwrap();
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
        PistonSealLeak.apply(&mut same, &[0.0, 0.5]).unwrap();
        assert_eq!(same, base);
        assert!(PistonSealLeak.apply(&mut same, &[-1.0, 0.0]).is_err());
        assert!(PistonSealLeak.apply(&mut same, &[1e-8, 2.5]).is_err());
    }

    #[test]
    fn the_law_moves_the_leak_from_orifice_to_capillary_to_linear() {
        let kinds = |law: f64| {
            let mut f = meter_out();
            PistonSealLeak.apply(&mut f, &[1.0 * L_MIN_BAR, law]).unwrap();
            let mut k: Vec<String> = f.components.iter().filter(|c| c.id.starts_with("seal_leak")).map(|c| c.kind.clone()).collect();
            k.sort();
            k
        };
        assert_eq!(kinds(0.0), ["conductance"]);
        assert_eq!(kinds(1.0), ["capillary"]);
        assert_eq!(kinds(0.5), ["capillary", "conductance"]);
        assert_eq!(kinds(2.0), ["conductance"]);
        assert_eq!(kinds(1.5), ["capillary", "conductance"]);
        assert_eq!(shares(0.25), (0.75, 0.25, 0.0));
        assert_eq!(shares(1.75), (0.0, 0.25, 0.75));
    }

    #[test]
    fn the_linear_law_passes_the_orifice_flow_at_6_to_5_bar_and_is_linear_in_the_drop() {
        use gas::GasModel;
        let gas = gas::IdealGas::air();
        let c = 1.0 * L_MIN_BAR;
        let iso = blocks::iso6358::FlowCharacteristic::new(c, ISO_B).unwrap();
        let lin =
            blocks::iso6358::FlowCharacteristic::new(linear_equivalent() * c, LINEAR_B).unwrap().with_laminar_ratio(LINEAR_B_LAM).unwrap();
        let t = 293.15;
        let (up, down) = (gas.state_pt(6e5, t), gas.state_pt(5e5, t));
        let a = lin.mass_flow(up.p, up.t, down.p, down.t);
        assert!((a / iso.mass_flow(up.p, up.t, down.p, down.t) - 1.0).abs() < 1e-9, "{a}");
        // the same drop at another mean pressure passes the same flow; twice the drop twice the flow
        assert!((lin.mass_flow(3e5, t, 2e5, t) / a - 1.0).abs() < 1e-9);
        assert!((lin.mass_flow(7e5, t, 5e5, t) / a - 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_capillary_of_equal_size_passes_the_orifice_flow_at_6_to_5_bar() {
        use blocks::block::{Block, Ctx, PortFlow};
        use gas::GasModel;
        let gas = gas::IdealGas::air();
        let c = 1.0 * L_MIN_BAR;
        let iso = blocks::iso6358::FlowCharacteristic::new(c, ISO_B).unwrap();
        let capillary = blocks::capillary::Capillary { k: capillary_equivalent() * c };
        let (up, down) = (gas.state_pt(6e5, 293.15), gas.state_pt(5e5, 293.15));
        let ctx = Ctx { t: 0.0, gas: &gas, states: &[], pneumatic: &[up, down], mechanical: &[], signals: &[] };
        let mut out = [PortFlow::default(); 2];
        capillary.flows(&ctx, &mut out);
        let orifice = iso.mass_flow(up.p, up.t, down.p, down.t);
        // equal within the difference between the block's gas constant and 287.05
        assert!((out[0].mdot / orifice - 1.0).abs() < 2e-3, "{} vs {orifice}", out[0].mdot);
        // and the laws differ elsewhere: at 6 → 1 bar the orifice chokes, the capillary does not
        let vent = gas.state_pt(1e5, 293.15);
        let ctx = Ctx { pneumatic: &[up, vent], ..ctx };
        capillary.flows(&ctx, &mut out);
        assert!(out[0].mdot > 2.0 * iso.mass_flow(up.p, up.t, vent.p, vent.t));
    }
}
