//! Real gas: truncated virial equation of state with thermodynamically
//! consistent caloric properties.
//!
//! Thermal EOS (mass-based coefficients, ρ [kg/m³], T [K], p [Pa]):
//!
//!   p = ρ R T (1 + B ρ + C ρ² + D ρ³),  B [m³/kg], C [m⁶/kg²], D [m⁹/kg³],
//!
//! each coefficient a short series in τ = T0/T (T0 = 300 K):
//! X(T) = Σᵢ xᵢ τⁱ, i = 0..3. Everything else follows from the residual
//! Helmholtz energy (a standard departure-function construction, e.g. Span,
//! "Multiparameter Equations of State", 2000, ch. 3)
//!
//!   a_r/(R T) = B ρ + C ρ²/2 + D ρ³/3,
//!
//! added to the ideal-gas part of [`SemiPerfectGas`] of the same gas:
//! - Z = 1 + ρ ∂(a_r/RT)/∂ρ (the EOS above);
//! - u = u0(T) − R T² ∂(a_r/RT)/∂T, cv = (∂u/∂T)_ρ, h = u + p/ρ;
//! - T (∂p/∂T)_ρ and (∂p/∂ρ)_T in closed form, cp = cv + T (∂p/∂T)²_ρ /
//!   (ρ² (∂p/∂ρ)_T).
//!
//! With Sₖ = Σᵢ cₖᵢ τⁱ, S′ₖ = Σᵢ i cₖᵢ τⁱ (= −T dSₖ/dT) and
//! S″ₖ = Σᵢ i(i−1) cₖᵢ τⁱ (k = 1, 2, 3 for B, C, D):
//! - p = ρRT (1 + Σ Sₖ ρᵏ),  (∂p/∂ρ)_T = RT (1 + Σ (k+1) Sₖ ρᵏ),
//! - T (∂p/∂T)_ρ = ρRT (1 + Σ (Sₖ − S′ₖ) ρᵏ),
//! - u = u0(T) + RT Σ S′ₖ ρᵏ/k,  cv = cv0(T) − R Σ S″ₖ ρᵏ/k.
//!
//! So u, cv, cp, T(∂p/∂T)_ρ and (∂p/∂ρ)_T are exactly consistent with p(ρ, T):
//! Eq. 12 holds identically, which the chamber equations (paper Eq. 13/14)
//! rely on. The enthalpy reference is that of the ideal part:
//! h(ρ → 0, 298.15 K) = 0.
//!
//! Coefficients: the 12 numbers per gas were fitted by
//! tests/data/make_gas_fixture.py with one weighted linear least-squares
//! problem on Z (relative), (h − h0)/(RT) and (cv − cv0)/R against CoolProp
//! 8.0.0 ('Air' pseudo-pure, 'Nitrogen') on 200–500 K × 0.1–310 bar.
//!
//! Accuracy against CoolProp (5 K × 30-pressure check grid, docs/gas.md):
//! - 250–400 K, 1–10 bar: Z within 0.045 % (air) / 0.030 % (N2);
//! - 250–400 K, 1–300 bar: Z within 0.16 % / 0.15 %, cp within 0.31 % /
//!   0.36 %, enthalpy departure h − h0 within 162 / 189 J/kg;
//! - below 220 K and above 160 bar (ρ > 310 kg/m³) Z errors exceed 0.3 %,
//!   up to 1.2 % in Z and 2.3 % in cp at 200 K, 300 bar: the cubic in ρ
//!   cannot follow the near-critical isotherms there.
//!
//! Valid range: 200–500 K and 0–300 bar except the corner just named; best
//! 250–400 K. Outside it the formulas extrapolate smoothly; for
//! ρ ≤ 400 kg/m³ and 150 K ≤ T ≤ 1200 K they are checked to stay finite with
//! p, (∂p/∂ρ)_T, cv and cp − cv positive. [`GasModel::density`] returns NaN
//! only if no root can be found (possible far outside that domain).

use crate::semi_perfect::{R_AIR, R_NITROGEN};
use crate::{GasError, GasModel, SemiPerfectGas};

/// Number of terms τ⁰..τ³ of each virial coefficient.
const N_TAU: usize = 4;

/// Reducing temperature T0 of the fitted series [K].
const T0_FIT: f64 = 300.0;

/// Air: rows B [m³/kg], C [m⁶/kg²], D [m⁹/kg³]; columns the coefficients of
/// τ⁰..τ³ with τ = 300 K / T. Produced by tests/data/make_gas_fixture.py.
const VIRIAL_AIR: [[f64; N_TAU]; 3] = [
    [0.0013065406534438103, -0.0010392645044598433, -0.0005365399184332289, 4.383803714271133e-05],
    [8.294551928285862e-07, 2.0526381995401338e-07, -2.1738075502264785e-07, 2.8169403577982353e-07],
    [5.066202835749657e-09, -5.808626303107941e-09, 4.257240479611616e-09, -1.1929413445536973e-09],
];

/// Nitrogen: same layout as [`VIRIAL_AIR`]. Produced by
/// tests/data/make_gas_fixture.py.
const VIRIAL_NITROGEN: [[f64; N_TAU]; 3] = [
    [0.0014377864056366635, -0.0010628973452006525, -0.0005660051778712206, 5.546516509896852e-05],
    [8.199201440693604e-07, 5.155317293849359e-07, -3.988813171776355e-07, 3.255544072524209e-07],
    [6.417793890310228e-09, -7.508812148269588e-09, 5.546192128364424e-09, -1.546778067291177e-09],
];

/// Real gas with a truncated virial EOS and a semi-perfect ideal part.
#[derive(Debug, Clone, PartialEq)]
pub struct VirialGas {
    name: String,
    r: f64,
    t0: f64,
    coef: [[f64; N_TAU]; 3],
    ideal: SemiPerfectGas,
}

/// Values of the three series at one temperature: index k−1 for B, C, D.
struct Series {
    /// Sₖ = Σ cₖᵢ τⁱ (the coefficient itself).
    s0: [f64; 3],
    /// S′ₖ = Σ i cₖᵢ τⁱ = −T dSₖ/dT.
    s1: [f64; 3],
    /// S″ₖ = Σ i(i−1) cₖᵢ τⁱ.
    s2: [f64; 3],
}

impl VirialGas {
    /// Model from an ideal part, the reducing temperature `t0` [K] and the
    /// coefficients `[B, C, D]`, each `[x0, x1, x2, x3]` of Σ xᵢ (t0/T)ⁱ in
    /// SI mass units. The gas constant is that of `ideal`.
    pub fn new(name: impl Into<String>, ideal: SemiPerfectGas, t0: f64, coefficients: [[f64; N_TAU]; 3]) -> Result<Self, GasError> {
        if !(t0.is_finite() && t0 > 0.0) {
            return Err(GasError::InvalidTemperature(t0));
        }
        for (k, row) in coefficients.iter().enumerate() {
            for (i, &v) in row.iter().enumerate() {
                if !v.is_finite() {
                    let letter = ["B", "C", "D"][k];
                    return Err(GasError::NonFiniteCoefficient { name: format!("{letter}[{i}]"), value: v });
                }
            }
        }
        Ok(Self { name: name.into(), r: ideal.r(), t0, coef: coefficients, ideal })
    }

    /// Air (CoolProp pseudo-pure 'Air'), R = 287.05 J/(kg K).
    pub fn air() -> Self {
        let ideal = SemiPerfectGas::air();
        debug_assert_eq!(ideal.r(), R_AIR);
        Self { name: "virial_air".to_owned(), r: R_AIR, t0: T0_FIT, coef: VIRIAL_AIR, ideal }
    }

    /// Nitrogen N2, R = 296.8 J/(kg K).
    pub fn nitrogen() -> Self {
        let ideal = SemiPerfectGas::nitrogen();
        debug_assert_eq!(ideal.r(), R_NITROGEN);
        Self { name: "virial_nitrogen".to_owned(), r: R_NITROGEN, t0: T0_FIT, coef: VIRIAL_NITROGEN, ideal }
    }

    /// The ideal-gas part (same gas, ρ → 0 limit).
    pub fn ideal_part(&self) -> &SemiPerfectGas {
        &self.ideal
    }

    /// Virial coefficients [B, C, D] at temperature `t` (m³/kg, m⁶/kg², m⁹/kg³).
    pub fn virial_coefficients(&self, t: f64) -> [f64; 3] {
        self.series(t).s0
    }

    fn series(&self, t: f64) -> Series {
        let tau = self.t0 / t;
        let mut s = Series { s0: [0.0; 3], s1: [0.0; 3], s2: [0.0; 3] };
        for (k, row) in self.coef.iter().enumerate() {
            let mut taui = 1.0;
            for (i, &c) in row.iter().enumerate() {
                let fi = i as f64;
                let term = c * taui;
                s.s0[k] += term;
                s.s1[k] += fi * term;
                s.s2[k] += fi * (fi - 1.0) * term;
                taui *= tau;
            }
        }
        s
    }
}

/// [ρ, ρ², ρ³].
fn powers(rho: f64) -> [f64; 3] {
    [rho, rho * rho, rho * rho * rho]
}

impl GasModel for VirialGas {
    fn name(&self) -> &str {
        &self.name
    }

    fn r(&self) -> f64 {
        self.r
    }

    fn pressure(&self, rho: f64, t: f64) -> f64 {
        let s = self.series(t);
        let rk = powers(rho);
        let z = 1.0 + s.s0[0] * rk[0] + s.s0[1] * rk[1] + s.s0[2] * rk[2];
        rho * self.r * t * z
    }

    fn dp_drho(&self, rho: f64, t: f64) -> f64 {
        let s = self.series(t);
        let rk = powers(rho);
        let f = 1.0 + 2.0 * s.s0[0] * rk[0] + 3.0 * s.s0[1] * rk[1] + 4.0 * s.s0[2] * rk[2];
        self.r * t * f
    }

    fn t_dp_dt(&self, rho: f64, t: f64) -> f64 {
        let s = self.series(t);
        let rk = powers(rho);
        let f = 1.0 + (s.s0[0] - s.s1[0]) * rk[0] + (s.s0[1] - s.s1[1]) * rk[1] + (s.s0[2] - s.s1[2]) * rk[2];
        rho * self.r * t * f
    }

    fn cv(&self, rho: f64, t: f64) -> f64 {
        let s = self.series(t);
        let rk = powers(rho);
        let res = s.s2[0] * rk[0] + s.s2[1] * rk[1] / 2.0 + s.s2[2] * rk[2] / 3.0;
        self.ideal.cv0(t) - self.r * res
    }

    fn cp(&self, rho: f64, t: f64) -> f64 {
        let tpt = self.t_dp_dt(rho, t);
        self.cv(rho, t) + tpt * tpt / (t * rho * rho * self.dp_drho(rho, t))
    }

    fn internal_energy(&self, rho: f64, t: f64) -> f64 {
        let s = self.series(t);
        let rk = powers(rho);
        let res = s.s1[0] * rk[0] + s.s1[1] * rk[1] / 2.0 + s.s1[2] * rk[2] / 3.0;
        self.ideal.u0(t) + self.r * t * res
    }

    /// Safeguarded Newton iteration on p(ρ, T) − p = 0, started from the
    /// ideal-gas density. Each evaluation tightens a bracket [lo, hi] (lo
    /// starts at 0 where p(0) − p < 0); a Newton step that leaves the
    /// bracket, or a non-positive slope, is replaced by bisection (or by
    /// doubling while no upper bound is known). Non-positive or non-finite
    /// `p`, `t` give the ideal-gas value p/(RT).
    fn density(&self, p: f64, t: f64) -> f64 {
        let rho_ideal = p / (self.r * t);
        if !(rho_ideal.is_finite() && rho_ideal > 0.0) {
            return rho_ideal;
        }
        let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
        let mut rho = rho_ideal;
        for _ in 0..200 {
            let f = self.pressure(rho, t) - p;
            if f == 0.0 {
                return rho;
            }
            if f < 0.0 {
                lo = rho;
            } else {
                hi = rho;
            }
            let slope = self.dp_drho(rho, t);
            let newton = rho - f / slope;
            let next = if slope > 0.0 && newton > lo && newton < hi {
                newton
            } else if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * rho
            };
            if (next - rho).abs() <= 1e-14 * next || (hi.is_finite() && hi - lo <= 1e-15 * hi) {
                return next;
            }
            rho = next;
        }
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{check_consistency, check_finite_grid, check_round_trip, fixture, Row, AIR_CSV, NITROGEN_CSV};

    fn cases() -> [(VirialGas, Vec<Row>); 2] {
        [(VirialGas::air(), fixture(AIR_CSV)), (VirialGas::nitrogen(), fixture(NITROGEN_CSV))]
    }

    /// Rows of the acceptance range 250–400 K, 1–300 bar.
    fn in_target(r: &Row) -> bool {
        (250.0..=400.0).contains(&r.t) && (1e5..=300e5).contains(&r.p)
    }

    #[test]
    fn compressibility_matches_coolprop() {
        for (g, rows) in cases() {
            let (mut worst, mut worst_low, mut n) = (0.0_f64, 0.0_f64, 0);
            for r in rows.iter().filter(|r| in_target(r)) {
                // Z at the reference (ρ, T) ...
                let e_rho_t = g.compressibility(r.rho, r.t) / r.z - 1.0;
                // ... and at the reference (p, T), through `density`.
                let z_pt = r.p / (g.density(r.p, r.t) * g.r() * r.t);
                let e_p_t = z_pt / r.z - 1.0;
                let e = e_rho_t.abs().max(e_p_t.abs());
                worst = worst.max(e);
                assert!(e <= 5e-3, "{}: Z error {e:.2e} at T = {}, p = {}", g.name(), r.t, r.p);
                if r.p <= 10e5 {
                    worst_low = worst_low.max(e);
                    assert!(e <= 1e-3, "{}: Z error {e:.2e} at T = {}, p = {}", g.name(), r.t, r.p);
                }
                n += 1;
            }
            assert!(n >= 70, "only {n} fixture rows in 250-400 K, 1-300 bar");
            println!("{}: max |Z error| 1-300 bar {:.3} %, 1-10 bar {:.3} % ({n} states)", g.name(), 100.0 * worst, 100.0 * worst_low);
        }
    }

    #[test]
    fn caloric_properties_match_coolprop() {
        // Bounds stated in the module header and docs/gas.md (250–400 K, 1–300 bar).
        for (g, rows) in cases() {
            let (mut e_cp, mut e_hdep, mut e_h) = (0.0_f64, 0.0_f64, 0.0_f64);
            for r in rows.iter().filter(|r| in_target(r)) {
                e_cp = e_cp.max((g.cp(r.rho, r.t) / r.cp - 1.0).abs());
                let h = g.enthalpy(r.rho, r.t);
                e_hdep = e_hdep.max((h - g.ideal_part().h0(r.t) - r.h_dep).abs());
                e_h = e_h.max((h - r.h).abs());
            }
            println!(
                "{}: 250-400 K, 1-300 bar: max |cp error| {:.3} %, max |h - h0 error| {:.0} J/kg, \
                 max |h error| {:.0} J/kg",
                g.name(),
                100.0 * e_cp,
                e_hdep,
                e_h
            );
            assert!(e_cp <= 4e-3, "{}: cp error {e_cp}", g.name());
            assert!(e_hdep <= 200.0, "{}: h departure error {e_hdep}", g.name());
            assert!(e_h <= 200.0, "{}: h error {e_h}", g.name());

            // Outside the acceptance range: reported only.
            let (mut ez, mut ecp) = (0.0_f64, 0.0_f64);
            for r in rows.iter().filter(|r| r.t <= 500.0 && r.p >= 1e5) {
                ez = ez.max((g.compressibility(r.rho, r.t) / r.z - 1.0).abs());
                ecp = ecp.max((g.cp(r.rho, r.t) / r.cp - 1.0).abs());
            }
            println!("{}: 200-500 K, 1-300 bar: max |Z error| {:.3} %, max |cp error| {:.3} %", g.name(), 100.0 * ez, 100.0 * ecp);
        }
    }

    #[test]
    fn real_gas_effects_have_the_right_sign() {
        for (g, rows) in cases() {
            // Z < 1 at 250 K, 50 bar and Z > 1 at 400 K, 300 bar, as the reference.
            for r in rows.iter().filter(|r| (r.t == 250.0 && r.p == 50e5) || (r.t == 400.0 && r.p == 300e5)) {
                let z = g.compressibility(r.rho, r.t);
                assert_eq!(z < 1.0, r.z < 1.0, "{} at {} K, {} Pa", g.name(), r.t, r.p);
            }
            // Joule–Thomson: at room temperature h falls with pressure at
            // constant T, as in the reference (h_dep < 0 at 300 K, 100 bar).
            let t = 300.0;
            let rho = g.density(100e5, t);
            assert!(g.enthalpy(rho, t) < g.ideal_part().h0(t));
            // Real-gas cp exceeds the ideal-gas cp at 300 K, 100 bar.
            assert!(g.cp(rho, t) > g.ideal_part().cp0(t));
        }
    }

    #[test]
    fn tends_to_semi_perfect_at_low_density() {
        for (g, _) in cases() {
            let sp = g.ideal_part();
            for &t in &[160.0, 250.0, 300.0, 420.0, 900.0] {
                let rho = 1e-6;
                // Energies are compared on the scale R T (h may be near 0).
                let rt = g.r() * t;
                let close = |a: f64, b: f64, scale: f64, what: &str| {
                    assert!((a - b).abs() <= 1e-8 * scale, "{what} at {t}: {a} vs {b}");
                };
                let p = sp.pressure(rho, t);
                close(g.pressure(rho, t), p, p, "p");
                close(g.t_dp_dt(rho, t), p, p, "T dp/dT");
                close(g.dp_drho(rho, t), sp.dp_drho(rho, t), rt, "dp/drho");
                close(g.cv(rho, t), sp.cv(rho, t), sp.cv(rho, t), "cv");
                close(g.cp(rho, t), sp.cp(rho, t), sp.cp(rho, t), "cp");
                close(g.internal_energy(rho, t), sp.internal_energy(rho, t), rt, "u");
                close(g.enthalpy(rho, t), sp.enthalpy(rho, t), rt, "h");
                // Departures are first order in ρ: doubling ρ doubles them.
                let (r1, r2) = (1e-3, 2e-3);
                let dep = |rho: f64| g.cp(rho, t) - sp.cp(rho, t);
                let ratio = dep(r2) / dep(r1);
                assert!((ratio - 2.0).abs() < 1e-2, "cp departure ratio {ratio} at {t}");
                // (Z − 1)/ρ → B(T).
                let [b, c, _] = g.virial_coefficients(t);
                let slope = (g.compressibility(r1, t) - 1.0) / r1;
                assert!((slope - b).abs() <= 1.01 * c.abs() * r1 + 1e-15, "B at {t}");
            }
        }
    }

    #[test]
    fn thermodynamic_consistency() {
        for (g, _) in cases() {
            for &t in &[155.0, 230.0, 275.0, 320.0, 410.0, 640.0, 1150.0] {
                for &rho in &[1e-3, 0.8, 10.0, 60.0, 150.0, 300.0, 390.0] {
                    check_consistency(&g, rho, t);
                    check_round_trip(&g, rho, t);
                }
            }
        }
    }

    #[test]
    fn density_round_trips_at_extremes_and_handles_bad_input() {
        for (g, _) in cases() {
            for &t in &[150.0, 1200.0] {
                for &rho in &[1e-6, 1e-2, 399.0] {
                    check_round_trip(&g, rho, t);
                }
            }
            assert_eq!(g.density(0.0, 300.0), 0.0);
            assert!(g.density(-1.0, 300.0) < 0.0);
            assert!(!g.density(f64::NAN, 300.0).is_finite());
        }
    }

    #[test]
    fn finite_everywhere() {
        check_finite_grid(&VirialGas::air());
        check_finite_grid(&VirialGas::nitrogen());
    }

    #[test]
    fn constructor_validates() {
        let sp = SemiPerfectGas::air();
        let g = VirialGas::new("copy", sp.clone(), T0_FIT, VIRIAL_AIR).expect("valid");
        assert_eq!(g.name(), "copy");
        assert_eq!(g.pressure(50.0, 280.0), VirialGas::air().pressure(50.0, 280.0));
        assert_eq!(VirialGas::new("x", sp.clone(), 0.0, VIRIAL_AIR), Err(GasError::InvalidTemperature(0.0)));
        let mut bad = VIRIAL_AIR;
        bad[1][2] = f64::INFINITY;
        assert!(matches!(
            VirialGas::new("x", sp.clone(), T0_FIT, bad),
            Err(GasError::NonFiniteCoefficient { ref name, .. }) if name == "C[2]"
        ));
        // All-zero coefficients reproduce the ideal part exactly.
        let z = VirialGas::new("ideal", sp.clone(), T0_FIT, [[0.0; N_TAU]; 3]).expect("valid");
        assert_eq!(z.pressure(120.0, 310.0), sp.pressure(120.0, 310.0));
        assert!((z.cp(120.0, 310.0) - sp.cp(120.0, 310.0)).abs() < 1e-12 * sp.cp(120.0, 310.0));
    }
}
