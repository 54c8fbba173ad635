//! Gas property models used by every block.
//!
//! A [`GasModel`] is a thermal and caloric equation of state in the variables
//! (ρ, T): density [kg/m³] and temperature [K]. Chambers integrate mass and
//! temperature (paper Eq. 5, 13/14), so (ρ, T) is the natural pair; the
//! inverse `density(p, T)` is needed only at boundaries (sources, initial
//! conditions).
//!
//! Implementations:
//! - [`IdealGas`]: perfect gas with constant cp (paper Eq. 15–17);
//! - [`SemiPerfectGas`]: ideal thermal EOS with cp(T) from NASA 7-coefficient
//!   polynomials (McBride, Zehe & Gordon 2002), valid 200–1000 K;
//! - [`VirialGas`]: real gas, virial EOS p = ρRT(1 + Bρ + Cρ² + Dρ³) with
//!   temperature-dependent coefficients fitted to reference data, caloric
//!   properties from departure functions so that Eq. 12–14 hold exactly.
//!
//! All enthalpies share the reference h(ρ→0, T_ref = 298.15 K) = 0 within one
//! model; only differences of h enter the equations.
//!
//! Constructors with user data validate them and return [`GasError`]; the
//! built-in gases (`air()`, `nitrogen()`) cannot fail. Fitted coefficients
//! come from tests/data/make_gas_fixture.py (CoolProp reference data); the
//! fit method and the accuracy reached are in docs/gas.md.

#[cfg(test)]
mod doc_numbers;
mod ideal;
mod semi_perfect;
mod virial;

pub use ideal::IdealGas;
pub use semi_perfect::SemiPerfectGas;
pub use virial::VirialGas;

use std::fmt::Debug;

/// Reference temperature of all enthalpies [K]: h(ρ→0, `T_REF`) = 0.
pub const T_REF: f64 = 298.15;

/// Invalid arguments given to a gas-model constructor.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GasError {
    /// The specific gas constant must be finite and strictly positive.
    #[error("specific gas constant R must be finite and > 0, got {0} J/(kg K)")]
    InvalidGasConstant(f64),
    /// A specific heat must be finite and strictly positive.
    #[error("specific heat must be finite and > 0, got {0} J/(kg K)")]
    InvalidHeatCapacity(f64),
    /// A reducing temperature must be finite and strictly positive.
    #[error("reducing temperature must be finite and > 0, got {0} K")]
    InvalidTemperature(f64),
    /// A fitted coefficient is NaN or infinite.
    #[error("coefficient {name} is not finite: {value}")]
    NonFiniteCoefficient {
        /// Which coefficient (e.g. "a3", "C[2]").
        name: String,
        /// Its value.
        value: f64,
    },
}

/// Checks that `r` is a usable gas constant.
fn check_r(r: f64) -> Result<f64, GasError> {
    if r.is_finite() && r > 0.0 {
        Ok(r)
    } else {
        Err(GasError::InvalidGasConstant(r))
    }
}

/// Thermodynamic state of gas at a port or in a chamber.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GasState {
    /// Absolute pressure [Pa].
    pub p: f64,
    /// Temperature [K].
    pub t: f64,
    /// Density [kg/m³].
    pub rho: f64,
    /// Specific enthalpy [J/kg] (model reference, see module docs).
    pub h: f64,
}

/// Equation of state p(ρ, T) with consistent caloric properties.
///
/// All functions take density ρ [kg/m³] and temperature T [K] and return SI
/// values. Implementations must be cheap (they run inside the ODE right-hand
/// side) and must never panic for ρ > 0, T > 0.
pub trait GasModel: Debug + Send + Sync {
    /// Short name for reports ("ideal", "semi_perfect", "virial_air").
    fn name(&self) -> &str;
    /// Specific gas constant R [J/(kg K)].
    fn r(&self) -> f64;
    /// Pressure p(ρ, T) [Pa].
    fn pressure(&self, rho: f64, t: f64) -> f64;
    /// (∂p/∂ρ)_T [Pa m³/kg] (used by the polytropic index, Eq. 22).
    fn dp_drho(&self, rho: f64, t: f64) -> f64;
    /// T·(∂p/∂T)_ρ [Pa], the term of Eq. 12–14 (equals p for an ideal gas, Eq. 15).
    fn t_dp_dt(&self, rho: f64, t: f64) -> f64;
    /// Specific heat at constant volume cv(ρ, T) [J/(kg K)].
    fn cv(&self, rho: f64, t: f64) -> f64;
    /// Specific heat at constant pressure cp(ρ, T) [J/(kg K)].
    fn cp(&self, rho: f64, t: f64) -> f64;
    /// Specific internal energy u(ρ, T) [J/kg].
    fn internal_energy(&self, rho: f64, t: f64) -> f64;
    /// Specific enthalpy h(ρ, T) = u + p/ρ [J/kg].
    fn enthalpy(&self, rho: f64, t: f64) -> f64 {
        self.internal_energy(rho, t) + self.pressure(rho, t) / rho
    }
    /// Density ρ(p, T) [kg/m³], the inverse of `pressure` at fixed T.
    fn density(&self, p: f64, t: f64) -> f64;
    /// Ratio of specific heats γ = cp/cv at (ρ, T).
    fn gamma(&self, rho: f64, t: f64) -> f64 {
        self.cp(rho, t) / self.cv(rho, t)
    }
    /// Compressibility factor Z = p/(ρRT).
    fn compressibility(&self, rho: f64, t: f64) -> f64 {
        self.pressure(rho, t) / (rho * self.r() * t)
    }
    /// Slopes of c_v and of T·(∂p/∂T)_ρ in (ρ, T), for exact Jacobians of
    /// the energy balance (Eq. 13): `[∂cv/∂ρ, ∂cv/∂T, ∂(T p_T)/∂ρ, ∂(T p_T)/∂T]`.
    /// Default: central differences of [`GasModel::cv`] and
    /// [`GasModel::t_dp_dt`] (relative error about 1e-10); the ideal and
    /// semi-perfect models give them in closed form.
    fn second_derivatives(&self, rho: f64, t: f64) -> [f64; 4] {
        let (dr, dt) = (1e-5 * rho.abs().max(1e-3), 1e-5 * t);
        let by_rho = |f: &dyn Fn(f64, f64) -> f64| (f(rho + dr, t) - f(rho - dr, t)) / (2.0 * dr);
        let by_t = |f: &dyn Fn(f64, f64) -> f64| (f(rho, t + dt) - f(rho, t - dt)) / (2.0 * dt);
        let cv = |r: f64, t: f64| self.cv(r, t);
        let tpt = |r: f64, t: f64| self.t_dp_dt(r, t);
        [by_rho(&cv), by_t(&cv), by_rho(&tpt), by_t(&tpt)]
    }
    /// Full state from pressure and temperature.
    fn state_pt(&self, p: f64, t: f64) -> GasState {
        let rho = self.density(p, t);
        GasState { p, t, rho, h: self.enthalpy(rho, t) }
    }
    /// Full state from density and temperature.
    fn state_rho_t(&self, rho: f64, t: f64) -> GasState {
        GasState { p: self.pressure(rho, t), t, rho, h: self.enthalpy(rho, t) }
    }
}

/// Helpers shared by the unit tests of the three models: the CoolProp fixture
/// reader and model-independent thermodynamic consistency checks.
#[cfg(test)]
pub(crate) mod test_support {
    use super::GasModel;

    /// CoolProp reference data for air, written by tests/data/make_gas_fixture.py.
    pub(crate) const AIR_CSV: &str = include_str!("../../../tests/data/coolprop_air.csv");
    /// CoolProp reference data for nitrogen, written by tests/data/make_gas_fixture.py.
    pub(crate) const NITROGEN_CSV: &str = include_str!("../../../tests/data/coolprop_nitrogen.csv");

    /// One reference state (see the header of the CSV files for definitions).
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Row {
        pub t: f64,
        pub p: f64,
        pub rho: f64,
        pub z: f64,
        pub cp: f64,
        pub h: f64,
        pub h_dep: f64,
        pub cp0: f64,
        pub h0: f64,
    }

    /// Parses a fixture CSV ('#' lines are comments, the first other line is
    /// the header).
    pub(crate) fn fixture(csv: &str) -> Vec<Row> {
        let mut lines = csv.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#'));
        let header: Vec<&str> = lines.next().expect("header line").split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("column {name} missing"));
        let idx = [
            col("T_K"),
            col("p_Pa"),
            col("rho_kg_m3"),
            col("Z"),
            col("cp_J_kgK"),
            col("h_J_kg"),
            col("h_dep_J_kg"),
            col("cp0_J_kgK"),
            col("h0_J_kg"),
        ];
        let rows: Vec<Row> = lines
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse::<f64>().expect("number")).collect();
                Row {
                    t: v[idx[0]],
                    p: v[idx[1]],
                    rho: v[idx[2]],
                    z: v[idx[3]],
                    cp: v[idx[4]],
                    h: v[idx[5]],
                    h_dep: v[idx[6]],
                    cp0: v[idx[7]],
                    h0: v[idx[8]],
                }
            })
            .collect();
        assert!(rows.len() > 100, "fixture too small: {}", rows.len());
        rows
    }

    fn assert_close(what: &str, a: f64, b: f64, tol: f64, scale: f64, rho: f64, t: f64) {
        assert!(
            (a - b).abs() <= tol * scale,
            "{what} at rho = {rho}, T = {t}: {a} vs {b} (diff {}, allowed {})",
            (a - b).abs(),
            tol * scale
        );
    }

    /// Checks, by central finite differences with relative step 1e-5, that the
    /// derivative functions of `g` are those of its p(ρ, T) and u(ρ, T), and
    /// that the caloric identities hold:
    /// - (∂p/∂ρ)_T and T (∂p/∂T)_ρ;
    /// - cv = (∂u/∂T)_ρ;
    /// - Eq. 12: (∂u/∂ρ)_T = −(T (∂p/∂T)_ρ − p)/ρ²;
    /// - cp = cv + T (∂p/∂T)²_ρ / (ρ² (∂p/∂ρ)_T), and cp = (∂h/∂T)_p using
    ///   `density` to stay on the isobar;
    /// - h = u + p/ρ.
    pub(crate) fn check_consistency(g: &dyn GasModel, rho: f64, t: f64) {
        const TOL: f64 = 1e-7;
        let p = g.pressure(rho, t);
        let (dr, dt) = (1e-5 * rho, 1e-5 * t);

        let dpdr_fd = (g.pressure(rho + dr, t) - g.pressure(rho - dr, t)) / (2.0 * dr);
        let dpdr = g.dp_drho(rho, t);
        assert_close("dp/drho", dpdr, dpdr_fd, TOL, dpdr.abs() + p / rho, rho, t);

        let tpt_fd = t * (g.pressure(rho, t + dt) - g.pressure(rho, t - dt)) / (2.0 * dt);
        let tpt = g.t_dp_dt(rho, t);
        assert_close("T dp/dT", tpt, tpt_fd, TOL, tpt.abs() + p, rho, t);

        let cv_fd = (g.internal_energy(rho, t + dt) - g.internal_energy(rho, t - dt)) / (2.0 * dt);
        let cv = g.cv(rho, t);
        assert_close("cv = du/dT", cv, cv_fd, TOL, cv.abs(), rho, t);

        let dudr_fd = (g.internal_energy(rho + dr, t) - g.internal_energy(rho - dr, t)) / (2.0 * dr);
        let dudr = -(tpt - p) / (rho * rho);
        assert_close("Eq. 12 du/drho", dudr_fd, dudr, TOL, p / (rho * rho), rho, t);

        let cp = g.cp(rho, t);
        let cp_eos = cv + tpt * tpt / (t * rho * rho * dpdr);
        assert_close("cp - cv", cp, cp_eos, 1e-10, cp.abs(), rho, t);

        let rho_p = g.density(p, t + dt);
        let rho_m = g.density(p, t - dt);
        let cp_fd = (g.enthalpy(rho_p, t + dt) - g.enthalpy(rho_m, t - dt)) / (2.0 * dt);
        assert_close("cp = dh/dT|p", cp, cp_fd, 1e-6, cp.abs(), rho, t);

        let h = g.enthalpy(rho, t);
        let u = g.internal_energy(rho, t);
        assert_close("h = u + p/rho", h, u + p / rho, 1e-12, u.abs() + p / rho, rho, t);

        let gamma = g.gamma(rho, t);
        assert_close("gamma", gamma, cp / cv, 1e-12, gamma, rho, t);
    }

    /// Checks density(pressure(ρ, T), T) = ρ to 1e-10 relative.
    pub(crate) fn check_round_trip(g: &dyn GasModel, rho: f64, t: f64) {
        let p = g.pressure(rho, t);
        let back = g.density(p, t);
        assert!(((back - rho) / rho).abs() < 1e-10, "{}: density(pressure({rho}, {t})) = {back}", g.name());
        let s = g.state_pt(p, t);
        assert!(((s.rho - rho) / rho).abs() < 1e-10);
        assert_eq!(s.h, g.enthalpy(s.rho, t));
    }

    /// No NaN or infinity, and physically signed results, for
    /// ρ ∈ [1e-6, 400] kg/m³ (log-spaced) and T ∈ [150, 1200] K.
    pub(crate) fn check_finite_grid(g: &dyn GasModel) {
        for i in 0..=40 {
            let rho = 1e-6 * (4e8_f64).powf(f64::from(i) / 40.0);
            for j in 0..=42 {
                let t = 150.0 + 25.0 * f64::from(j);
                let vals = [
                    g.pressure(rho, t),
                    g.dp_drho(rho, t),
                    g.t_dp_dt(rho, t),
                    g.cv(rho, t),
                    g.cp(rho, t),
                    g.internal_energy(rho, t),
                    g.enthalpy(rho, t),
                    g.gamma(rho, t),
                    g.compressibility(rho, t),
                ];
                assert!(vals.iter().all(|v| v.is_finite()), "{}: non-finite value at rho = {rho}, T = {t}: {vals:?}", g.name());
                let p = vals[0];
                assert!(p > 0.0 && vals[1] > 0.0 && vals[3] > 0.0 && vals[4] > vals[3]);
                let back = g.density(p, t);
                assert!(back.is_finite() && ((back - rho) / rho).abs() < 1e-9, "{}: density({p}, {t}) = {back}, expected {rho}", g.name());
            }
        }
    }
}
