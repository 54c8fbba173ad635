//! Perfect gas: ideal thermal equation of state with constant specific heats.
//!
//! Equations (SI units, ρ [kg/m³], T [K], p [Pa]):
//! - thermal EOS p = ρ R T, so (∂p/∂ρ)_T = R T and T (∂p/∂T)_ρ = p
//!   (paper Eq. 15, which turns Eq. 13/14 into Eq. 16/17);
//! - caloric EOS with constant cv and cp = R + cv (Mayer's relation):
//!   h = cp (T − T_ref), u = h − p/ρ = h − R T, with T_ref = 298.15 K
//!   ([`crate::T_REF`]), so that h(T_ref) = 0 as for the other models.
//!
//! Constructors: [`IdealGas::air`] (R = 287.05, cv = 717.8 J/(kg K)),
//! [`IdealGas::nitrogen`] (R = 296.8, cv = 743.0 J/(kg K)), [`IdealGas::new`].
//!
//! Assumptions: no intermolecular forces (Z = 1) and frozen vibrational
//! modes (cp independent of T). For air, compared with CoolProp: cp is within
//! 0.35 % of the ideal-gas cp0 between 200 and 350 K (0.84 % off at 400 K),
//! and real air's Z departs from 1 by up to 0.19 % at 2 bar, 0.47 % at 5 bar
//! and 0.92 % at 10 bar over 250–400 K (see docs/gas.md); use
//! [`crate::SemiPerfectGas`] or [`crate::VirialGas`] when that matters. The
//! formulas themselves are valid for any ρ > 0, T > 0.

use crate::{check_r, GasError, GasModel, T_REF};

/// Perfect gas with constant cp and cv.
#[derive(Debug, Clone, PartialEq)]
pub struct IdealGas {
    name: &'static str,
    r: f64,
    cv: f64,
}

impl IdealGas {
    /// Perfect gas with specific gas constant `r` and constant-volume
    /// specific heat `cv`, both in J/(kg K) and strictly positive.
    pub fn new(r: f64, cv: f64) -> Result<Self, GasError> {
        let r = check_r(r)?;
        if !(cv.is_finite() && cv > 0.0) {
            return Err(GasError::InvalidHeatCapacity(cv));
        }
        Ok(Self { name: "ideal", r, cv })
    }

    /// Dry air: R = 287.05 J/(kg K), cv = 717.8 J/(kg K), cp = 1004.85 J/(kg K),
    /// γ = cp/cv ≈ 1.3999.
    pub fn air() -> Self {
        Self { name: "ideal_air", r: 287.05, cv: 717.8 }
    }

    /// Nitrogen N2: R = 296.8 J/(kg K), cv = 743.0 J/(kg K) (ideal-gas value
    /// near 300 K), cp = 1039.8 J/(kg K), γ ≈ 1.399.
    pub fn nitrogen() -> Self {
        Self { name: "ideal_nitrogen", r: 296.8, cv: 743.0 }
    }

    /// Constant specific heat at constant pressure cp = R + cv [J/(kg K)].
    fn cp_const(&self) -> f64 {
        self.r + self.cv
    }
}

impl GasModel for IdealGas {
    fn name(&self) -> &str {
        self.name
    }

    fn r(&self) -> f64 {
        self.r
    }

    fn pressure(&self, rho: f64, t: f64) -> f64 {
        rho * self.r * t
    }

    fn dp_drho(&self, _rho: f64, t: f64) -> f64 {
        self.r * t
    }

    fn t_dp_dt(&self, rho: f64, t: f64) -> f64 {
        // Eq. 15: T (∂p/∂T)_ρ = T ρ R = p.
        rho * self.r * t
    }

    fn cv(&self, _rho: f64, _t: f64) -> f64 {
        self.cv
    }

    fn second_derivatives(&self, rho: f64, t: f64) -> [f64; 4] {
        // c_v constant; T p_T = ρRT
        [0.0, 0.0, self.r * t, rho * self.r]
    }

    fn cp(&self, _rho: f64, _t: f64) -> f64 {
        self.cp_const()
    }

    fn internal_energy(&self, _rho: f64, t: f64) -> f64 {
        self.cp_const() * (t - T_REF) - self.r * t
    }

    fn enthalpy(&self, _rho: f64, t: f64) -> f64 {
        self.cp_const() * (t - T_REF)
    }

    fn density(&self, p: f64, t: f64) -> f64 {
        p / (self.r * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{check_consistency, check_finite_grid, check_round_trip};

    #[test]
    fn air_constants_and_gamma() {
        let g = IdealGas::air();
        assert_eq!(g.r(), 287.05);
        assert_eq!(g.cv(1.0, 300.0), 717.8);
        assert!((g.cp(1.0, 300.0) - (287.05 + 717.8)).abs() < 1e-12);
        let gamma = g.gamma(1.2, 293.15);
        assert!((gamma - 1.4).abs() < 1e-3, "gamma = {gamma}");
        // γ is independent of the state for a perfect gas.
        assert_eq!(gamma, g.gamma(50.0, 900.0));
    }

    #[test]
    fn hand_computed_state() {
        let g = IdealGas::air();
        // Standard-ish air: 1.2 kg/m³ at 20 °C → 100 978.449 Pa.
        let p = g.pressure(1.2, 293.15);
        assert!((p - 1.2 * 287.05 * 293.15).abs() < 1e-9);
        assert!((p - 100_978.449).abs() < 1e-6);
        assert_eq!(g.t_dp_dt(1.2, 293.15), p); // Eq. 15
        assert_eq!(g.compressibility(1.2, 293.15), 1.0);
        // h = cp (T − 298.15): at 398.15 K it is 100 cp.
        assert!((g.enthalpy(3.0, 398.15) - 100.0 * 1004.85).abs() < 1e-8);
        assert!(g.enthalpy(3.0, T_REF).abs() < 1e-12);
        // u = cv T − cp T_ref.
        let u = g.internal_energy(3.0, 350.0);
        assert!((u - (717.8 * 350.0 - 1004.85 * T_REF)).abs() < 1e-8);
        let s = g.state_pt(6e5, 300.0);
        assert!((s.rho - 6e5 / (287.05 * 300.0)).abs() < 1e-12);
        assert!((s.h - 1004.85 * (300.0 - T_REF)).abs() < 1e-9);
    }

    #[test]
    fn nitrogen_matches_reference_near_room_temperature() {
        let g = IdealGas::nitrogen();
        assert_eq!(g.name(), "ideal_nitrogen");
        assert!((g.gamma(1.0, 300.0) - 1.4).abs() < 2e-3);
        // Within 0.1 % of CoolProp's ideal-gas cp0 between 250 and 325 K.
        for r in crate::test_support::fixture(crate::test_support::NITROGEN_CSV) {
            if (250.0..=325.0).contains(&r.t) {
                assert!((g.cp(1.0, r.t) / r.cp0 - 1.0).abs() < 1e-3, "cp0 at {}", r.t);
            }
        }
    }

    #[test]
    fn constructor_validates() {
        assert!(IdealGas::new(296.8, 742.2).is_ok());
        assert_eq!(IdealGas::new(0.0, 717.8), Err(GasError::InvalidGasConstant(0.0)));
        assert_eq!(IdealGas::new(-1.0, 717.8), Err(GasError::InvalidGasConstant(-1.0)));
        assert!(matches!(IdealGas::new(f64::NAN, 717.8), Err(GasError::InvalidGasConstant(_))));
        assert_eq!(IdealGas::new(287.05, 0.0), Err(GasError::InvalidHeatCapacity(0.0)));
        assert!(matches!(IdealGas::new(287.05, f64::INFINITY), Err(GasError::InvalidHeatCapacity(_))));
        let n2 = IdealGas::new(296.8, 742.2).expect("valid");
        assert_eq!(n2.name(), "ideal");
        assert!((n2.cp(1.0, 300.0) - 1039.0).abs() < 1e-9);
    }

    #[test]
    fn thermodynamic_consistency() {
        let g = IdealGas::air();
        for &t in &[160.0, 250.0, 300.0, 450.0, 1100.0] {
            for &rho in &[1e-4, 0.5, 12.0, 120.0, 390.0] {
                check_consistency(&g, rho, t);
                check_round_trip(&g, rho, t);
            }
        }
    }

    #[test]
    fn finite_everywhere() {
        check_finite_grid(&IdealGas::air());
    }
}
