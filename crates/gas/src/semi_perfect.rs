//! Semi-perfect gas: ideal thermal equation of state with a temperature
//! dependent heat capacity cp(T).
//!
//! Equations (SI units, ρ [kg/m³], T [K], p [Pa]):
//! - thermal EOS p = ρ R T, hence (∂p/∂ρ)_T = R T and T (∂p/∂T)_ρ = p
//!   (paper Eq. 15);
//! - cp in the NASA 7-coefficient polynomial form (McBride, Zehe & Gordon,
//!   NASA TP-2002-211556): cp/R = a1 + a2 T + a3 T² + a4 T³ + a5 T⁴, valid on
//!   [`SemiPerfectGas::T_MIN`, `SemiPerfectGas::T_MAX`] = [200 K, 1000 K];
//! - h(T) = ∫ cp dT with h(T_ref = 298.15 K) = 0 ([`crate::T_REF`]) (the
//!   NASA a6 constant is replaced by this reference), u = h − R T,
//!   cv = cp − R. All of them depend on T only.
//!
//! Outside 200–1000 K the polynomial is not used:
//! - below 200 K cp is held at cp(200 K) (the real ideal-gas cp of air and N2
//!   is flat there: vibration is frozen), h continues linearly;
//! - above 1000 K cp continues linearly with its slope at 1000 K (clamped at
//!   ≥ 0), h quadratically. At 1200 K this is 0.2 % (air) and 0.4 % (N2)
//!   below CoolProp's cp0.
//!
//! cp, h and u are continuous everywhere (cp is C⁰, h and u are C¹).
//!
//! Coefficients: fitted by tests/data/make_gas_fixture.py to CoolProp 8.0.0's
//! ideal-gas cp0 of 'Air' (pseudo-pure, with R = 287.05 J/(kg K) as
//! [`crate::IdealGas::air`]) and 'Nitrogen' (R = 296.8 J/(kg K)), sampled
//! every 5 K, minimising the largest relative error (minimax, linear
//! programme). Fit error over 200–1000 K:
//! - air: max 0.057 %, rms 0.040 % (max 0.65 J/(kg K)); h0 within 65 J/kg;
//! - nitrogen: max 0.071 %, rms 0.050 % (max 0.83 J/(kg K)); h0 within 73 J/kg.

use crate::{check_r, GasError, GasModel, T_REF};

/// Ideal-gas NASA cp/R coefficients a1..a5 for air (T in K), from
/// tests/data/make_gas_fixture.py.
const NASA_AIR: [f64; 5] =
    [3.587466749351422, -0.0008496975125801769, 2.029472824741113e-06, -5.262235041398701e-10, -2.6868061800917285e-13];

/// Ideal-gas NASA cp/R coefficients a1..a5 for nitrogen (T in K), from
/// tests/data/make_gas_fixture.py.
const NASA_NITROGEN: [f64; 5] =
    [3.55525151351082, -0.0003468778781296736, 1.4038915545016355e-07, 1.7059079265431895e-09, -1.1245278385315294e-12];

/// Specific gas constant of air used throughout the crate [J/(kg K)].
pub(crate) const R_AIR: f64 = 287.05;
/// Specific gas constant of nitrogen used throughout the crate [J/(kg K)].
pub(crate) const R_NITROGEN: f64 = 296.8;

/// Ideal thermal EOS with cp(T) from a NASA 7-coefficient polynomial.
#[derive(Debug, Clone, PartialEq)]
pub struct SemiPerfectGas {
    name: String,
    r: f64,
    /// cp/R polynomial coefficients a1..a5.
    a: [f64; 5],
    /// cp(T_MIN) [J/(kg K)].
    cp_lo: f64,
    /// cp(T_MAX) [J/(kg K)].
    cp_hi: f64,
    /// dcp/dT used above T_MAX [J/(kg K²)].
    slope_hi: f64,
    /// Polynomial enthalpy primitive at T_MIN and T_MAX [J/kg].
    prim_lo: f64,
    prim_hi: f64,
    /// Unreferenced enthalpy at T_REF [J/kg].
    h_offset: f64,
}

impl SemiPerfectGas {
    /// Lower end of the polynomial's range [K].
    pub const T_MIN: f64 = 200.0;
    /// Upper end of the polynomial's range [K].
    pub const T_MAX: f64 = 1000.0;

    /// Model from a gas constant `r` [J/(kg K)] and NASA coefficients
    /// `a` = [a1, …, a5] of cp/R (T in K). Fails if R is not positive, a
    /// coefficient is not finite, or cp is not positive on 200–1000 K.
    pub fn from_nasa(name: impl Into<String>, r: f64, a: [f64; 5]) -> Result<Self, GasError> {
        let r = check_r(r)?;
        for (i, &v) in a.iter().enumerate() {
            if !v.is_finite() {
                return Err(GasError::NonFiniteCoefficient { name: format!("a{}", i + 1), value: v });
            }
        }
        for i in 0..=80 {
            let t = Self::T_MIN + (Self::T_MAX - Self::T_MIN) * f64::from(i) / 80.0;
            let cp = r * poly_cp_r(&a, t);
            if !(cp.is_finite() && cp > 0.0) {
                return Err(GasError::InvalidHeatCapacity(cp));
            }
        }
        Ok(Self::build(name.into(), r, a))
    }

    /// Dry air (CoolProp pseudo-pure 'Air'), R = 287.05 J/(kg K).
    pub fn air() -> Self {
        Self::build("semi_perfect_air".to_owned(), R_AIR, NASA_AIR)
    }

    /// Nitrogen N2, R = 296.8 J/(kg K).
    pub fn nitrogen() -> Self {
        Self::build("semi_perfect_nitrogen".to_owned(), R_NITROGEN, NASA_NITROGEN)
    }

    fn build(name: String, r: f64, a: [f64; 5]) -> Self {
        let cp_lo = r * poly_cp_r(&a, Self::T_MIN);
        let cp_hi = r * poly_cp_r(&a, Self::T_MAX);
        let slope_hi = (r * poly_dcp_r(&a, Self::T_MAX)).max(0.0);
        let prim_lo = r * poly_h_rt(&a, Self::T_MIN) * Self::T_MIN;
        let prim_hi = r * poly_h_rt(&a, Self::T_MAX) * Self::T_MAX;
        let mut g = Self { name, r, a, cp_lo, cp_hi, slope_hi, prim_lo, prim_hi, h_offset: 0.0 };
        g.h_offset = g.raw_enthalpy(T_REF);
        g
    }

    /// Ideal-gas specific heat at constant pressure cp0(T) [J/(kg K)].
    pub fn cp0(&self, t: f64) -> f64 {
        if t < Self::T_MIN {
            self.cp_lo
        } else if t > Self::T_MAX {
            self.cp_hi + self.slope_hi * (t - Self::T_MAX)
        } else {
            self.r * poly_cp_r(&self.a, t)
        }
    }

    /// Ideal-gas specific heat at constant volume cv0(T) = cp0 − R [J/(kg K)].
    pub fn cv0(&self, t: f64) -> f64 {
        self.cp0(t) - self.r
    }

    /// Ideal-gas enthalpy h0(T) [J/kg], zero at 298.15 K.
    pub fn h0(&self, t: f64) -> f64 {
        self.raw_enthalpy(t) - self.h_offset
    }

    /// Ideal-gas internal energy u0(T) = h0 − R T [J/kg].
    pub fn u0(&self, t: f64) -> f64 {
        self.h0(t) - self.r * t
    }

    /// ∫ cp dT with an arbitrary constant.
    fn raw_enthalpy(&self, t: f64) -> f64 {
        if t < Self::T_MIN {
            self.prim_lo + self.cp_lo * (t - Self::T_MIN)
        } else if t > Self::T_MAX {
            let d = t - Self::T_MAX;
            self.prim_hi + d * (self.cp_hi + 0.5 * self.slope_hi * d)
        } else {
            self.r * poly_h_rt(&self.a, t) * t
        }
    }
}

/// cp/R = a1 + a2 T + a3 T² + a4 T³ + a5 T⁴.
fn poly_cp_r(a: &[f64; 5], t: f64) -> f64 {
    a[0] + t * (a[1] + t * (a[2] + t * (a[3] + t * a[4])))
}

/// d(cp/R)/dT [1/K].
fn poly_dcp_r(a: &[f64; 5], t: f64) -> f64 {
    a[1] + t * (2.0 * a[2] + t * (3.0 * a[3] + t * 4.0 * a[4]))
}

/// (∫ cp/R dT)/T without constant: a1 + a2 T/2 + a3 T²/3 + a4 T³/4 + a5 T⁴/5.
fn poly_h_rt(a: &[f64; 5], t: f64) -> f64 {
    a[0] + t * (a[1] / 2.0 + t * (a[2] / 3.0 + t * (a[3] / 4.0 + t * a[4] / 5.0)))
}

impl GasModel for SemiPerfectGas {
    fn name(&self) -> &str {
        &self.name
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
        rho * self.r * t
    }

    fn cv(&self, _rho: f64, t: f64) -> f64 {
        self.cv0(t)
    }

    fn second_derivatives(&self, rho: f64, t: f64) -> [f64; 4] {
        // c_v(T) = c_p0(T) − R, piecewise as in `cp0`; T p_T = ρRT
        let dcv = if t < Self::T_MIN {
            0.0
        } else if t > Self::T_MAX {
            self.slope_hi
        } else {
            self.r * poly_dcp_r(&self.a, t)
        };
        [0.0, dcv, self.r * t, rho * self.r]
    }

    fn cp(&self, _rho: f64, t: f64) -> f64 {
        self.cp0(t)
    }

    fn internal_energy(&self, _rho: f64, t: f64) -> f64 {
        self.u0(t)
    }

    fn enthalpy(&self, _rho: f64, t: f64) -> f64 {
        self.h0(t)
    }

    fn density(&self, p: f64, t: f64) -> f64 {
        p / (self.r * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{check_consistency, check_finite_grid, check_round_trip, fixture, AIR_CSV, NITROGEN_CSV};

    /// (model, fixture, stated max relative cp fit error, stated max abs cp error).
    fn cases() -> [(SemiPerfectGas, &'static str, f64, f64); 2] {
        [(SemiPerfectGas::air(), AIR_CSV, 5.7e-4, 0.65), (SemiPerfectGas::nitrogen(), NITROGEN_CSV, 7.1e-4, 0.83)]
    }

    #[test]
    fn cp0_matches_coolprop_within_stated_fit_error() {
        for (g, csv, max_rel, _) in cases() {
            let rows = fixture(csv);
            let mut worst = 0.0_f64;
            for r in &rows {
                let e = (g.cp0(r.t) / r.cp0 - 1.0).abs();
                worst = worst.max(e);
                assert!(e <= max_rel, "{}: cp0({}) = {} vs {}", g.name(), r.t, g.cp0(r.t), r.cp0);
            }
            println!("{}: max |cp0 error| on fixture = {:.3e}", g.name(), worst);
            // The fixture covers the full polynomial range.
            assert!(rows.iter().any(|r| r.t == 200.0) && rows.iter().any(|r| r.t == 1000.0));
        }
    }

    #[test]
    fn h0_matches_coolprop_within_integrated_fit_error() {
        // |Δh0(T)| ≤ max|Δcp0| · |T − T_ref| since both are zero at T_ref.
        for (g, csv, _, max_abs_cp) in cases() {
            for r in fixture(csv) {
                let bound = max_abs_cp * (r.t - T_REF).abs() + 1e-6;
                let e = (g.h0(r.t) - r.h0).abs();
                assert!(e <= bound, "{}: h0({}) off by {e} J/kg (bound {bound})", g.name(), r.t);
            }
        }
    }

    #[test]
    fn reference_state_and_ideal_eos() {
        for (g, _, _, _) in cases() {
            assert!(g.enthalpy(1.0, T_REF).abs() < 1e-9);
            assert!((g.internal_energy(1.0, T_REF) + g.r() * T_REF).abs() < 1e-9);
            let (rho, t) = (7.3, 333.0);
            let p = rho * g.r() * t;
            assert!((g.pressure(rho, t) - p).abs() < 1e-9 * p);
            assert_eq!(g.t_dp_dt(rho, t), g.pressure(rho, t)); // Eq. 15
            assert!((g.compressibility(rho, t) - 1.0).abs() < 1e-15);
            assert!((g.cp(rho, t) - g.cv(rho, t) - g.r()).abs() < 1e-9);
            // Caloric properties do not depend on density.
            assert_eq!(g.enthalpy(0.01, t), g.enthalpy(300.0, t));
        }
    }

    #[test]
    fn gamma_matches_reference() {
        let g = SemiPerfectGas::air();
        assert!((g.gamma(1.0, 300.0) - 1.4).abs() < 1e-3, "gamma(300) = {}", g.gamma(1.0, 300.0));
        // γ0 = cp0/(cp0 − R); |dγ0/dcp0| = R/cv0² ≤ 287.05/714² < 5.7e-4 per
        // J/(kg K) on the fixture, so the 0.65 J/(kg K) fit error bounds it.
        for r in fixture(AIR_CSV) {
            let reference = r.cp0 / (r.cp0 - g.r());
            assert!((g.gamma(1.0, r.t) - reference).abs() < 0.65 * 5.7e-4, "gamma at {}", r.t);
        }
        // Vibrational excitation lowers γ at high temperature.
        assert!(g.gamma(1.0, 900.0) < g.gamma(1.0, 500.0));
        assert!(g.gamma(1.0, 900.0) < 1.36);
    }

    #[test]
    fn continuous_at_range_ends_and_extended_as_documented() {
        for (g, _, _, _) in cases() {
            let eps = 1e-9;
            for tb in [SemiPerfectGas::T_MIN, SemiPerfectGas::T_MAX] {
                assert!((g.cp0(tb - eps) - g.cp0(tb + eps)).abs() < 1e-6);
                assert!((g.h0(tb - eps) - g.h0(tb + eps)).abs() < 1e-5);
            }
            // Below 200 K: constant cp, linear h.
            assert_eq!(g.cp0(150.0), g.cp0(SemiPerfectGas::T_MIN));
            let dh = g.h0(SemiPerfectGas::T_MIN) - g.h0(150.0);
            assert!((dh - 50.0 * g.cp0(150.0)).abs() < 1e-8 * dh.abs());
            // Above 1000 K: cp linear with the polynomial's end slope.
            let slope_in = (g.cp0(1000.0) - g.cp0(999.99)) / 0.01;
            let slope_out = (g.cp0(1100.0) - g.cp0(1000.0)) / 100.0;
            assert!(slope_out > 0.0);
            assert!((slope_out - slope_in).abs() < 1e-3 * slope_in);
            let curv = g.cp0(1200.0) - 2.0 * g.cp0(1100.0) + g.cp0(1000.0);
            assert!(curv.abs() < 1e-9);
        }
    }

    #[test]
    fn constructor_validates() {
        let a = NASA_AIR;
        assert!(SemiPerfectGas::from_nasa("x", R_AIR, a).is_ok());
        assert_eq!(SemiPerfectGas::from_nasa("x", -1.0, a), Err(GasError::InvalidGasConstant(-1.0)));
        let mut bad = a;
        bad[2] = f64::NAN;
        assert!(matches!(SemiPerfectGas::from_nasa("x", R_AIR, bad), Err(GasError::NonFiniteCoefficient { .. })));
        // cp/R = 1 − T/500 becomes negative above 500 K.
        assert!(matches!(SemiPerfectGas::from_nasa("x", R_AIR, [1.0, -2e-3, 0.0, 0.0, 0.0]), Err(GasError::InvalidHeatCapacity(_))));
        // Hand check: constant cp/R = 3.5 gives a perfect gas.
        let g = SemiPerfectGas::from_nasa("const", 287.0, [3.5, 0.0, 0.0, 0.0, 0.0]).expect("valid");
        assert_eq!(g.name(), "const");
        assert!((g.cp0(640.0) - 1004.5).abs() < 1e-9);
        assert!((g.h0(398.15) - 100.45e3).abs() < 1e-6);
        assert!((g.cp0(1100.0) - 1004.5).abs() < 1e-9);
        assert!((g.h0(1100.0) - 1004.5 * (1100.0 - T_REF)).abs() < 1e-6);
    }

    #[test]
    fn thermodynamic_consistency() {
        for (g, _, _, _) in cases() {
            for &t in &[160.0, 240.0, 300.0, 455.0, 870.0, 1150.0] {
                for &rho in &[1e-4, 0.9, 25.0, 380.0] {
                    check_consistency(&g, rho, t);
                    check_round_trip(&g, rho, t);
                }
            }
        }
    }

    #[test]
    fn finite_everywhere() {
        check_finite_grid(&SemiPerfectGas::air());
        check_finite_grid(&SemiPerfectGas::nitrogen());
    }
}
