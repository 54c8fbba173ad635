//! Thermodynamic properties of the working gas (air), per unit mass.
//!
//! Two models share one set of formulas:
//!
//! * **ideal gas** (the default, paper Eq. 15–17): p = ρ R T, u = c_v T,
//!   h = c_p T with c_p = c_v + R; R = 287.05 J/(kg K), c_v = 717.8 J/(kg K);
//! * **virial gas** (the optional "real gas" hidden effect, paper Eq. 12–14):
//!   the equation of state truncated after the second virial coefficient,
//!
//!   p = ρ R T (1 + B(T) ρ),
//!
//!   with B(T) [m³/kg] from the Tsonopoulos correlation
//!   (C. Tsonopoulos, "An empirical correlation of second virial
//!   coefficients", AIChE J. 20 (1974) 263–272),
//!
//!   B = (R T_c / p_c) [f⁰(T_r) + ω f¹(T_r)], T_r = T/T_c,
//!   f⁰ = 0.1445 − 0.330/T_r − 0.1385/T_r² − 0.0121/T_r³ − 0.000607/T_r⁸,
//!   f¹ = 0.0637 + 0.331/T_r² − 0.423/T_r³ − 0.008/T_r⁸,
//!
//!   using the pseudo-critical constants of air T_c = 132.53 K,
//!   p_c = 3.786 MPa and ω = 0.0335 (E. W. Lemmon et al., J. Phys. Chem.
//!   Ref. Data 29 (2000) 331). At 292 K this gives B = −9.3 cm³/mol
//!   (−3.2·10⁻⁴ m³/kg), within a cm³/mol of measured values for air.
//!
//!   The caloric properties follow from the equation of state, so that
//!   internal energy, enthalpy and the temperature equation are mutually
//!   consistent (paper Eq. 12): with (∂u/∂v)_T = T(∂p/∂T)_v − p,
//!
//!   u = c_v⁰ T − R T² B'(T) ρ,
//!   h = u + p/ρ = c_p⁰ T + R T ρ (B − T B'),
//!   c_v = (∂u/∂T)_ρ = c_v⁰ − R ρ (2 T B' + T² B''),
//!   T (∂p/∂T)_ρ = ρ R T (1 + ρ (B + T B')).
//!
//!   With B ≡ 0 all of these reduce to the ideal gas, which is how the ideal
//!   model is evaluated (one code path).
//!
//! * **second and third virial coefficients** (for high pressures, where B
//!   alone is not enough), p = ρRT(1 + Bρ + Cρ²), with B after Tsonopoulos
//!   as above and C after Orbey & Vera (H. Orbey, J. H. Vera, AIChE J. 29
//!   (1983) 107): C = (R T_c/p_c)²[g⁰(T_r) + ω g¹(T_r)],
//!   g⁰ = 0.01407 + 0.02432/T_r^2.8 − 0.00313/T_r^10.5,
//!   g¹ = −0.02676 + 0.01770/T_r^2.8 + 0.040/T_r³ − 0.003/T_r⁶ − 0.00228/T_r^10.5,
//!   and the caloric properties that follow: u = c_v⁰T − RT²(B'ρ + C'ρ²/2),
//!   c_v = c_v⁰ − Rρ(2TB' + T²B'') − Rρ²(2TC' + T²C'')/2,
//!   T(∂p/∂T)_ρ = ρRT(1 + ρ(B + TB') + ρ²(C + TC')). Constants of nitrogen:
//!   T_c = 126.19 K, p_c = 3.3958 MPa, ω = 0.0372 (Span et al., J. Phys.
//!   Chem. Ref. Data 29 (2000) 1361), R = 296.80, c_v⁰ = 743.0 J/(kg K).
//!   Against CoolProp its Z is within 0.5 % at 300 K up to 150 bar and
//!   within 2.5 % at 200 K, 150 bar — a different model from pneumo's
//!   virial gas, off where two honest implementations would be.

use crate::error::RigError;

/// Pseudo-critical temperature of air [K] (Lemmon et al. 2000).
const AIR_TC: f64 = 132.5306;
/// Pseudo-critical pressure of air [Pa] (Lemmon et al. 2000).
const AIR_PC: f64 = 3.786e6;
/// Acentric factor of air (Lemmon et al. 2000).
const AIR_OMEGA: f64 = 0.0335;

/// Which equation of state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GasLaw {
    /// p = ρ R T.
    Ideal,
    /// p = ρ R T (1 + B(T) ρ), B from Tsonopoulos (1974) for air.
    Virial,
    /// p = ρRT(1 + Bρ + Cρ²), B after Tsonopoulos, C after Orbey & Vera,
    /// with the critical constants (T_c [K], p_c [Pa], ω).
    VirialBC { tc: f64, pc: f64, omega: f64 },
}

/// The working gas: constants and the equation of state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gas {
    /// Specific gas constant R [J/(kg K)].
    pub r: f64,
    /// Specific heat at constant volume of the ideal-gas part c_v⁰ [J/(kg K)].
    pub cv: f64,
    /// Equation of state.
    pub law: GasLaw,
}

impl Default for Gas {
    fn default() -> Self {
        Gas { r: 287.05, cv: 717.8, law: GasLaw::Ideal }
    }
}

/// B(T) and its first two temperature derivatives [m³/kg, m³/(kg K), m³/(kg K²)].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Virial {
    pub b: f64,
    pub db: f64,
    pub d2b: f64,
}

/// C(T) and its first two temperature derivatives [m⁶/kg², per K, per K²].
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Third {
    pub c: f64,
    pub dc: f64,
    pub d2c: f64,
}

/// Σ c_n x^(−n) and its first two derivatives in x.
fn power_sum(terms: &[(f64, f64)], x: f64) -> (f64, f64, f64) {
    let (mut f, mut df, mut d2f) = (0.0, 0.0, 0.0);
    for &(n, c) in terms {
        let v = x.powf(-n);
        f += c * v;
        df += -n * c * v / x;
        d2f += n * (n + 1.0) * c * v / (x * x);
    }
    (f, df, d2f)
}

impl Gas {
    /// Nitrogen with second and third virial coefficients (see the module header).
    pub fn nitrogen() -> Gas {
        Gas { r: 296.80, cv: 743.0, law: GasLaw::VirialBC { tc: 126.19, pc: 3.3958e6, omega: 0.0372 } }
    }

    /// Nitrogen as an ideal gas.
    pub fn nitrogen_ideal() -> Gas {
        Gas { law: GasLaw::Ideal, ..Gas::nitrogen() }
    }

    /// C(T) and derivatives (zero unless [`GasLaw::VirialBC`]).
    pub(crate) fn third(&self, t: f64) -> Third {
        let GasLaw::VirialBC { tc, pc, omega } = self.law else { return Third::default() };
        let c0 = (self.r * tc / pc).powi(2);
        let w = omega;
        let terms = [
            (0.0, 0.01407 - 0.02676 * w),
            (2.8, 0.02432 + 0.01770 * w),
            (3.0, 0.040 * w),
            (6.0, -0.003 * w),
            (10.5, -0.00313 - 0.00228 * w),
        ];
        let (f, df, d2f) = power_sum(&terms, t / tc);
        Third { c: c0 * f, dc: c0 * df / tc, d2c: c0 * d2f / (tc * tc) }
    }

    /// Ratio of specific heats of the ideal-gas part, γ = c_p⁰/c_v⁰.
    pub fn gamma(&self) -> f64 {
        (self.cv + self.r) / self.cv
    }

    /// c_p⁰ = c_v⁰ + R.
    pub fn cp(&self) -> f64 {
        self.cv + self.r
    }

    pub(crate) fn validate(&self) -> Result<(), RigError> {
        if !(self.r > 0.0 && self.r.is_finite()) {
            return Err(RigError::invalid("rig.gas.r", self.r, "must be positive and finite"));
        }
        if !(self.cv > 0.0 && self.cv.is_finite()) {
            return Err(RigError::invalid("rig.gas.cv", self.cv, "must be positive and finite"));
        }
        Ok(())
    }

    /// B(T) and derivatives; zero for the ideal gas.
    pub(crate) fn virial(&self, t: f64) -> Virial {
        let (tc, pc, w) = match self.law {
            GasLaw::Ideal => return Virial { b: 0.0, db: 0.0, d2b: 0.0 },
            GasLaw::Virial => (AIR_TC, AIR_PC, AIR_OMEGA),
            GasLaw::VirialBC { tc, pc, omega } => (tc, pc, omega),
        };
        // B = b0 Σ c_n Tr^(−n); d/dT = (1/Tc) d/dTr
        let b0 = self.r * tc / pc;
        let terms = [
            (0.0, 0.1445 + 0.0637 * w),
            (1.0, -0.330),
            (2.0, -0.1385 + 0.331 * w),
            (3.0, -0.0121 - 0.423 * w),
            (8.0, -0.000607 - 0.008 * w),
        ];
        let (f, df, d2f) = power_sum(&terms, t / tc);
        Virial { b: b0 * f, db: b0 * df / tc, d2b: b0 * d2f / (tc * tc) }
    }

    /// Pressure p(ρ, T) [Pa].
    pub fn pressure(&self, rho: f64, t: f64) -> f64 {
        let (v, c) = (self.virial(t), self.third(t));
        rho * self.r * t * (1.0 + v.b * rho + c.c * rho * rho)
    }

    /// Density from pressure and temperature [kg/m³]: the positive root of
    /// R T B ρ² + R T ρ − p = 0, written in the cancellation-free form
    /// ρ = 2p / (R T + √((R T)² + 4 R T B p)).
    pub fn density(&self, p: f64, t: f64) -> f64 {
        if matches!(self.law, GasLaw::VirialBC { .. }) {
            // Newton on p(ρ) from the second-virial density
            let mut rho = {
                let v = self.virial(t);
                let rt = self.r * t;
                2.0 * p / (rt + (rt * rt + 4.0 * rt * v.b * p).max(0.0).sqrt())
            };
            for _ in 0..50 {
                let (v, c) = (self.virial(t), self.third(t));
                let rt = self.r * t;
                let f = rho * rt * (1.0 + v.b * rho + c.c * rho * rho) - p;
                let df = rt * (1.0 + 2.0 * v.b * rho + 3.0 * c.c * rho * rho);
                let next = if df > 0.0 { (rho - f / df).clamp(0.5 * rho, 2.0 * rho) } else { 0.5 * rho };
                if (next - rho).abs() <= 1e-15 * rho {
                    return next;
                }
                rho = next;
            }
            return rho;
        }
        let v = self.virial(t);
        let rt = self.r * t;
        let disc = (rt * rt + 4.0 * rt * v.b * p).max(0.0);
        2.0 * p / (rt + disc.sqrt())
    }

    /// Specific internal energy u(ρ, T) [J/kg] (zero at T = 0 for the ideal part).
    pub fn internal_energy(&self, rho: f64, t: f64) -> f64 {
        let (v, c) = (self.virial(t), self.third(t));
        self.cv * t - self.r * t * t * (v.db * rho + 0.5 * c.dc * rho * rho)
    }

    /// Specific enthalpy h(ρ, T) = u + p/ρ [J/kg].
    pub fn enthalpy(&self, rho: f64, t: f64) -> f64 {
        if matches!(self.law, GasLaw::VirialBC { .. }) {
            return self.internal_energy(rho, t) + self.pressure(rho, t) / rho;
        }
        let v = self.virial(t);
        self.cp() * t + self.r * t * rho * (v.b - t * v.db)
    }

    /// Specific heat at constant volume c_v(ρ, T) [J/(kg K)].
    pub fn cv_real(&self, rho: f64, t: f64) -> f64 {
        let (v, c) = (self.virial(t), self.third(t));
        self.cv - self.r * rho * (2.0 * t * v.db + t * t * v.d2b) - 0.5 * self.r * rho * rho * (2.0 * t * c.dc + t * t * c.d2c)
    }

    /// T (∂p/∂T) at constant ρ [Pa] (paper Eq. 13–15; equals p for the ideal gas).
    pub fn t_dp_dt(&self, rho: f64, t: f64) -> f64 {
        let (v, c) = (self.virial(t), self.third(t));
        rho * self.r * t * (1.0 + rho * (v.b + t * v.db) + rho * rho * (c.c + t * c.dc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn virial() -> Gas {
        Gas { law: GasLaw::Virial, ..Gas::default() }
    }

    #[test]
    fn ideal_is_ideal() {
        let g = Gas::default();
        let (rho, t) = (4.7, 292.0);
        assert_eq!(g.pressure(rho, t), rho * 287.05 * t);
        assert!((g.density(g.pressure(rho, t), t) - rho).abs() < 1e-14 * rho);
        assert_eq!(g.t_dp_dt(rho, t), g.pressure(rho, t));
        assert!((g.enthalpy(rho, t) - g.internal_energy(rho, t) - g.pressure(rho, t) / rho).abs() < 1e-9);
        assert!((g.gamma() - 1.39991).abs() < 1e-4);
    }

    #[test]
    fn second_virial_of_air_is_plausible() {
        // measured B of air near 290 K is about −8 to −10 cm³/mol
        let g = virial();
        let b_molar_cm3 = g.virial(292.0).b * 0.028_965 * 1e6;
        assert!((-11.0..-7.0).contains(&b_molar_cm3), "{b_molar_cm3}");
    }

    #[test]
    fn virial_derivatives_match_finite_differences() {
        let g = virial();
        let t = 292.0;
        let h = 1e-3;
        let fd = (g.virial(t + h).b - g.virial(t - h).b) / (2.0 * h);
        let fd2 = (g.virial(t + h).db - g.virial(t - h).db) / (2.0 * h);
        assert!((fd - g.virial(t).db).abs() < 1e-9 * fd.abs().max(1e-12));
        assert!((fd2 - g.virial(t).d2b).abs() < 1e-6 * fd2.abs().max(1e-15));
    }

    #[test]
    fn nitrogen_with_three_virial_terms_is_consistent_and_plausible() {
        let g = Gas::nitrogen();
        // Z of nitrogen from CoolProp (tests/data/coolprop_nitrogen.csv at the repository root)
        let z = |p: f64, t: f64| p / (g.density(p, t) * g.r * t);
        for (p, t, reference, tol) in
            [(150e5, 300.0, 1.0257, 0.006), (50e5, 200.0, 0.9022, 0.006), (100e5, 250.0, 0.9586, 0.006), (150e5, 200.0, 0.8503, 0.025)]
        {
            assert!((z(p, t) - reference).abs() < tol, "{p} Pa {t} K: {} vs {reference}", z(p, t));
        }
        // caloric consistency as for the virial gas
        let (rho, t) = (150.0, 250.0);
        let dr = 1e-4;
        let du_drho = (g.internal_energy(rho + dr, t) - g.internal_energy(rho - dr, t)) / (2.0 * dr);
        let expect = -(g.t_dp_dt(rho, t) - g.pressure(rho, t)) / (rho * rho);
        assert!((du_drho - expect).abs() < 1e-6 * expect.abs(), "{du_drho} {expect}");
        let dt = 1e-3;
        let du_dt = (g.internal_energy(rho, t + dt) - g.internal_energy(rho, t - dt)) / (2.0 * dt);
        assert!((du_dt - g.cv_real(rho, t)).abs() < 1e-6 * du_dt, "{du_dt}");
        let dp_dt = (g.pressure(rho, t + dt) - g.pressure(rho, t - dt)) / (2.0 * dt);
        assert!((t * dp_dt - g.t_dp_dt(rho, t)).abs() < 1e-6 * g.t_dp_dt(rho, t));
        assert!((g.density(g.pressure(rho, t), t) - rho).abs() < 1e-10 * rho);
    }

    #[test]
    fn caloric_properties_are_consistent_with_the_eos() {
        // (∂u/∂ρ)_T = −(T ∂p/∂T − p)/ρ² and c_v = (∂u/∂T)_ρ, by finite differences
        let g = virial();
        let (rho, t) = (8.0, 300.0);
        let dr = 1e-4;
        let du_drho = (g.internal_energy(rho + dr, t) - g.internal_energy(rho - dr, t)) / (2.0 * dr);
        let expect = -(g.t_dp_dt(rho, t) - g.pressure(rho, t)) / (rho * rho);
        assert!((du_drho - expect).abs() < 1e-6 * expect.abs(), "{du_drho} {expect}");
        let dt = 1e-3;
        let du_dt = (g.internal_energy(rho, t + dt) - g.internal_energy(rho, t - dt)) / (2.0 * dt);
        assert!((du_dt - g.cv_real(rho, t)).abs() < 1e-6 * du_dt, "{du_dt}");
        let p = g.pressure(rho, t);
        assert!((g.density(p, t) - rho).abs() < 1e-12 * rho);
        assert!((g.enthalpy(rho, t) - g.internal_energy(rho, t) - p / rho).abs() < 1e-8);
        // compressibility factor at 7 bar a few per mille below 1
        let z = p / (rho * g.r * t);
        assert!(z < 1.0 && z > 0.99);
    }
}
