//! Mass flow through a pneumatic restriction (valve, orifice, fitting)
//! described by its ISO 6358 flow characteristic.
//!
//! # Equations
//!
//! With `p1` the upstream (higher) and `p2` the downstream absolute
//! pressure, `r = p2 / p1` and `T1` the upstream stagnation temperature,
//! the mass flow rate is (paper Eq. 34, ISO 6358-1:2013)
//!
//! ```text
//! m_dot = C · ρ_ref · p1 · K_T · ω(r),     K_T = sqrt(T_ref / T1)   (Eq. 35)
//! ```
//!
//! where the flow function `ω` has three regions:
//!
//! * choked, `0 <= r <= b`:           `ω = 1`
//! * subsonic, `b < r <= b_lam`:      `ω = [1 − ((r − b)/(1 − b))²]^m`
//!   (`m = 0.5` is the elliptic law of the paper, Eq. 33; ISO 6358-1:2013
//!   generalises the exponent to the subsonic index `m`)
//! * laminar, `b_lam < r <= 1`:       `ω = ω(b_lam) · (1 − r)/(1 − b_lam)`
//!   (ISO 6358-1:2013 linear law near zero pressure drop).
//!
//! In the laminar region the flow is exactly linear in the pressure drop,
//! `m_dot = C ρ_ref K_T ω(b_lam)/(1 − b_lam) · (p1 − p2)`, so the flow is
//! continuous everywhere and Lipschitz as `r → 1` (the pure elliptic law has
//! an infinite slope at `r = 1`, which stiffens ODE solvers).
//!
//! Helpers for the characteristic times of a chamber discharging through
//! the restriction: the process-time order of magnitude `V/(γ C p_N)`
//! (paper Eq. 19) and the unloading time `K_T0 V/(γ C p_N)` obtained by
//! solving the de las Heras (2001) relation, paper Eq. 36, for `τ_U`.
//!
//! # Units
//!
//! SI throughout: pressures in Pa (absolute), temperatures in K, sonic
//! conductance `C` in m³/(s·Pa) (1 L/(min·bar) = 1e-3/60/1e5 m³/(s·Pa)),
//! density in kg/m³, mass flow in kg/s, volumes in m³, times in s.
//!
//! # Defaults and valid ranges
//!
//! * `C > 0` (finite), `0 <= b < 1`, `0 < m <= 1` (default 0.5),
//!   `b < b_lam < 1` (default 0.999).
//! * Reference (ISO 6358 "ANR" standard reference atmosphere):
//!   `T_ref = 293.15 K`, `p_ref = 100 kPa`, `ρ_ref = 1.185 kg/m³`; both
//!   `T_ref` and `ρ_ref` are configurable and must be > 0.
//!
//! # Assumptions
//!
//! * Quasi-steady flow: the restriction has no volume or inertia.
//! * The upstream side is the one with the higher pressure; its own
//!   temperature enters `K_T`. Reverse flow is handled by symmetry.
//! * `C` and `b` are constants (measured per ISO 6358 or estimated from an
//!   unloading test, Eq. 36); they do not depend on the flow direction.
//! * Robustness conventions: an upstream pressure `<= 0` (or NaN), or an
//!   upstream temperature `<= 0` (or NaN), gives zero flow; a downstream
//!   pressure `<= 0` is treated as vacuum (`r = 0`, choked flow), which keeps
//!   the flow continuous if a solver overshoots below zero. No function here
//!   returns NaN for such inputs.

use crate::params::{ParamSpec, Params, Range};
use thiserror::Error;
use units::dim;

/// Parameters every ISO 6358 path shares besides C and b: subsonic index,
/// laminar ratio and reference conditions (declared once, used by every
/// restriction and valve; blocks with several paths name C and b per path).
pub const SHARED: &[ParamSpec] = &[
    ParamSpec::quantity("m", dim::DIMENSIONLESS, Some(0.5), Range::Closed(0.1, 1.0), "", "subsonic index m (ISO 6358-1:2013)"),
    ParamSpec::quantity("b_lam", dim::DIMENSIONLESS, Some(0.999), Range::OpenUnit, "", "laminar pressure ratio"),
    ParamSpec::quantity("T_ref", dim::TEMPERATURE, Some(293.15), Range::GasTemperature, "K", "reference temperature (ANR)"),
    ParamSpec::quantity("rho_ref", dim::DENSITY, Some(1.185), Range::Positive, "kg/m3", "reference density (ANR)"),
];

/// The ISO 6358 parameter set of one restriction: C, b and [`SHARED`].
pub const PARAMS: &[ParamSpec] = crate::param_set!(
    &[
        ParamSpec::quantity("C", dim::CONDUCTANCE, None, Range::Positive, "L/min/bar", "sonic conductance C (ISO 6358)"),
        ParamSpec::quantity("b", dim::DIMENSIONLESS, None, Range::OpenUnit, "", "critical pressure ratio b (ISO 6358)"),
    ],
    SHARED
);

/// The characteristic named by the parameters `c` and `b` (e.g. "C", "b"
/// or "C_relief", "b_relief") with the [`SHARED`] ones.
pub fn from_params(p: &Params, c: &str, b: &str) -> Result<FlowCharacteristic, crate::BlockError> {
    with_shared(p, p.get(c), p.get(b))
}

/// The characteristic of sonic conductance `c` and critical ratio `b` with the [`SHARED`] parameters.
pub fn with_shared(p: &Params, c: f64, b: f64) -> Result<FlowCharacteristic, crate::BlockError> {
    Ok(FlowCharacteristic::new(c, b)?
        .with_subsonic_index(p.get("m"))?
        .with_laminar_ratio(p.get("b_lam"))?
        .with_reference(p.get("T_ref"), p.get("rho_ref"))?)
}

/// ISO 6358 reference (ANR) temperature (K).
pub const ANR_TEMPERATURE: f64 = 293.15;
/// ISO 6358 reference (ANR) pressure (Pa).
pub const ANR_PRESSURE: f64 = 100_000.0;
/// ISO 6358 reference (ANR) air density (kg/m³).
pub const ANR_DENSITY: f64 = 1.185;

/// Default subsonic index (elliptic law, paper Eq. 33).
const DEFAULT_SUBSONIC_INDEX: f64 = 0.5;
/// Default pressure ratio above which the laminar (linear) law is used.
const DEFAULT_LAMINAR_RATIO: f64 = 0.999;

/// Invalid parameter of a [`FlowCharacteristic`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FlowError {
    /// Sonic conductance not strictly positive and finite.
    #[error("C must be > 0 m^3/(s Pa), got {0}")]
    Conductance(f64),
    /// Critical pressure ratio outside [0, 1).
    #[error("b must be in [0, 1), got {0}")]
    CriticalRatio(f64),
    /// Subsonic index outside (0, 1].
    #[error("m must be in (0, 1], got {0}")]
    SubsonicIndex(f64),
    /// Laminar pressure ratio outside (b, 1).
    #[error("b_lam must be in (b, 1) = ({b}, 1), got {b_lam}")]
    LaminarRatio {
        /// Offending laminar ratio.
        b_lam: f64,
        /// Critical pressure ratio it must exceed.
        b: f64,
    },
    /// Reference temperature not strictly positive and finite.
    #[error("T_ref must be > 0 K, got {0}")]
    ReferenceTemperature(f64),
    /// Reference density not strictly positive and finite.
    #[error("rho_ref must be > 0 kg/m^3, got {0}")]
    ReferenceDensity(f64),
}

/// ISO 6358 flow characteristic of a restriction: sonic conductance `C`,
/// critical pressure ratio `b`, subsonic index `m`, laminar ratio `b_lam`
/// and the reference conditions `T_ref`, `ρ_ref`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowCharacteristic {
    c: f64,
    b: f64,
    m: f64,
    b_lam: f64,
    t_ref: f64,
    rho_ref: f64,
    /// Slope `ω(b_lam)/(1 − b_lam)` of the laminar line, a function of `b`,
    /// `m` and `b_lam` kept beside them ([`Self::with_laminar_line`]) so
    /// that a flow in the laminar region costs no power function.
    lam_slope: f64,
}

fn positive_finite(x: f64) -> bool {
    x > 0.0 && x.is_finite()
}

impl FlowCharacteristic {
    /// Characteristic with sonic conductance `c` (m³/(s·Pa)) and critical
    /// pressure ratio `b` (-); `m = 0.5`, `b_lam = 0.999`, ANR reference.
    ///
    /// Fails if `c` is not > 0 and finite, if `b` is outside `[0, 1)`, or
    /// if `b >= 0.999` (the default `b_lam` must exceed `b`).
    pub fn new(c: f64, b: f64) -> Result<Self, FlowError> {
        if !positive_finite(c) {
            return Err(FlowError::Conductance(c));
        }
        if !((0.0..1.0).contains(&b)) {
            return Err(FlowError::CriticalRatio(b));
        }
        if b >= DEFAULT_LAMINAR_RATIO {
            return Err(FlowError::LaminarRatio { b_lam: DEFAULT_LAMINAR_RATIO, b });
        }
        let fc = Self {
            c,
            b,
            m: DEFAULT_SUBSONIC_INDEX,
            b_lam: DEFAULT_LAMINAR_RATIO,
            t_ref: ANR_TEMPERATURE,
            rho_ref: ANR_DENSITY,
            lam_slope: 0.0,
        };
        Ok(fc.with_laminar_line())
    }

    /// Same characteristic with subsonic index `m` in `(0, 1]`.
    pub fn with_subsonic_index(self, m: f64) -> Result<Self, FlowError> {
        if !(m > 0.0 && m <= 1.0) {
            return Err(FlowError::SubsonicIndex(m));
        }
        Ok(Self { m, ..self }.with_laminar_line())
    }

    /// Same characteristic with laminar ratio `b_lam` in `(b, 1)`.
    pub fn with_laminar_ratio(self, b_lam: f64) -> Result<Self, FlowError> {
        if !(b_lam > self.b && b_lam < 1.0) {
            return Err(FlowError::LaminarRatio { b_lam, b: self.b });
        }
        Ok(Self { b_lam, ..self }.with_laminar_line())
    }

    /// Same characteristic referred to another reference temperature
    /// `t_ref` (K) and density `rho_ref` (kg/m³) (both > 0).
    pub fn with_reference(self, t_ref: f64, rho_ref: f64) -> Result<Self, FlowError> {
        if !positive_finite(t_ref) {
            return Err(FlowError::ReferenceTemperature(t_ref));
        }
        if !positive_finite(rho_ref) {
            return Err(FlowError::ReferenceDensity(rho_ref));
        }
        Ok(Self { t_ref, rho_ref, ..self })
    }

    /// Sonic conductance `C` (m³/(s·Pa)).
    pub fn c(&self) -> f64 {
        self.c
    }

    /// Critical pressure ratio `b` (-).
    pub fn b(&self) -> f64 {
        self.b
    }

    /// Subsonic index `m` (-).
    pub fn m(&self) -> f64 {
        self.m
    }

    /// Pressure ratio `b_lam` above which the laminar law applies (-).
    pub fn b_lam(&self) -> f64 {
        self.b_lam
    }

    /// Reference temperature `T_ref` (K).
    pub fn t_ref(&self) -> f64 {
        self.t_ref
    }

    /// Reference density `ρ_ref` (kg/m³).
    pub fn rho_ref(&self) -> f64 {
        self.rho_ref
    }

    /// The same characteristic with its laminar line's slope computed from
    /// its own `b`, `m` and `b_lam`.
    fn with_laminar_line(self) -> Self {
        let (w_lam, _) = self.subsonic(self.b_lam);
        Self { lam_slope: w_lam / (1.0 - self.b_lam), ..self }
    }

    /// Subsonic law `[1 − ((r − b)/(1 − b))²]^m` and its derivative with
    /// respect to `r`, for `b <= r <= b_lam`.
    fn subsonic(&self, r: f64) -> (f64, f64) {
        let span = 1.0 - self.b;
        let x = (r - self.b) / span;
        // 1 − x² > 0 strictly since r <= b_lam < 1; max guards rounding.
        let base = (1.0 - x * x).max(0.0);
        let w = if self.m == 0.5 {
            base.sqrt()
        } else if self.m == 1.0 {
            base
        } else {
            base.powf(self.m)
        };
        // dω/dr = m · ω / base · (−2x / (1 − b)); base > 0 here.
        let slope = if base > 0.0 { -2.0 * self.m * w * x / (base * span) } else { 0.0 };
        (w, slope)
    }

    /// `ω(r)` and `dω/dr`; `r` is clamped to `[0, 1]`, NaN counts as 1.
    fn omega_and_slope(&self, r: f64) -> (f64, f64) {
        let r = if r.is_nan() { 1.0 } else { r.clamp(0.0, 1.0) };
        if r <= self.b {
            (1.0, 0.0)
        } else if r <= self.b_lam {
            self.subsonic(r)
        } else {
            let g = self.lam_slope;
            (g * (1.0 - r), -g)
        }
    }

    /// Flow function `ω(r)` for `r` in `[0, 1]`; `r` outside is clamped
    /// (NaN is treated as `r = 1`, i.e. no flow). Result is in `[0, 1]`.
    pub fn omega(&self, r: f64) -> f64 {
        self.omega_and_slope(r).0
    }

    /// `C ρ_ref K_T`, or `None` when the upstream state gives no flow.
    fn upstream_factor(&self, p_up: f64, t_up: f64) -> Option<f64> {
        // Written so that NaN inputs fall into the `None` branch.
        if p_up > 0.0 && t_up > 0.0 {
            Some(self.c * self.rho_ref * (self.t_ref / t_up).sqrt())
        } else {
            None
        }
    }

    /// Mass flow (kg/s) from an upstream state (`p_up` (Pa), `t_up` (K)) to
    /// a downstream pressure `p_down <= p_up` (Pa); zero if
    /// `p_down >= p_up`. Never negative, never NaN.
    pub fn forward_flow(&self, p_up: f64, t_up: f64, p_down: f64) -> f64 {
        // Written so that a NaN pressure falls into the zero-flow branch.
        if p_down < p_up {
            match self.upstream_factor(p_up, t_up) {
                Some(k) => k * p_up * self.omega(p_down / p_up),
                None => 0.0,
            }
        } else {
            0.0
        }
    }

    /// `(∂/∂p_up, ∂/∂p_down)` of [`forward_flow`](Self::forward_flow),
    /// evaluated with `r = p_down / p_up` (also at `r = 1`, using the
    /// laminar slope).
    fn forward_derivatives(&self, p_up: f64, t_up: f64, p_down: f64) -> (f64, f64) {
        let Some(k) = self.upstream_factor(p_up, t_up) else {
            return (0.0, 0.0);
        };
        let r = p_down / p_up;
        let (w, slope) = self.omega_and_slope(r);
        if r <= 0.0 {
            // Vacuum (or clamped negative) downstream: choked, m = k · p_up.
            return (k, 0.0);
        }
        // m = k p1 ω(p2/p1): ∂m/∂p1 = k (ω − r ω'), ∂m/∂p2 = k ω'.
        (k * (w - r * slope), k * slope)
    }

    /// Signed mass flow (kg/s) from side `a` to side `b` (negative when `b`
    /// is upstream); the upstream side's own temperature enters `K_T`.
    pub fn mass_flow(&self, p_a: f64, t_a: f64, p_b: f64, t_b: f64) -> f64 {
        if p_a >= p_b {
            self.forward_flow(p_a, t_a, p_b)
        } else {
            -self.forward_flow(p_b, t_b, p_a)
        }
    }

    /// [`mass_flow`](Self::mass_flow) and
    /// [`mass_flow_derivatives`](Self::mass_flow_derivatives) together,
    /// `(ṁ, ∂ṁ/∂p_a, ∂ṁ/∂p_b)`: the same numbers, bit for bit, from one
    /// evaluation of `ω(r)` (the junction solve's Newton steps need both).
    pub fn mass_flow_and_derivatives(&self, p_a: f64, t_a: f64, p_b: f64, t_b: f64) -> (f64, f64, f64) {
        // The flow and slopes from `p_up` to `p_down < p_up`, as
        // `forward_flow` and `forward_derivatives` give them.
        let forward = |p_up: f64, t_up: f64, p_down: f64| -> (f64, f64, f64) {
            let Some(k) = self.upstream_factor(p_up, t_up) else {
                return (0.0, 0.0, 0.0);
            };
            let r = p_down / p_up;
            let (w, slope) = self.omega_and_slope(r);
            let flow = k * p_up * w;
            if r <= 0.0 {
                return (flow, k, 0.0);
            }
            (flow, k * (w - r * slope), k * slope)
        };
        if p_a > p_b {
            forward(p_a, t_a, p_b)
        } else if p_b > p_a {
            let (m, d_up, d_down) = forward(p_b, t_b, p_a);
            (-m, -d_down, -d_up)
        } else {
            let (da, db) = self.mass_flow_derivatives(p_a, t_a, p_b, t_b);
            (self.mass_flow(p_a, t_a, p_b, t_b), da, db)
        }
    }

    /// Analytic partial derivatives `(∂ṁ/∂p_a, ∂ṁ/∂p_b)` (kg/(s·Pa)) of
    /// [`mass_flow`](Self::mass_flow), for Newton steps and Jacobians.
    ///
    /// At `r = b_lam` the subsonic-side slope is returned (the flow has a
    /// kink there). At equal pressures the flow is linear in `p_a − p_b`
    /// on both sides; the slopes then differ only through `K_T` when
    /// `t_a != t_b`, and their mean is returned.
    pub fn mass_flow_derivatives(&self, p_a: f64, t_a: f64, p_b: f64, t_b: f64) -> (f64, f64) {
        if p_a > p_b {
            self.forward_derivatives(p_a, t_a, p_b)
        } else if p_b > p_a {
            let (d_up, d_down) = self.forward_derivatives(p_b, t_b, p_a);
            (-d_down, -d_up)
        } else {
            let (da1, db1) = self.forward_derivatives(p_a, t_a, p_b);
            let (db2, da2) = self.forward_derivatives(p_b, t_b, p_a);
            (0.5 * (da1 - da2), 0.5 * (db1 - db2))
        }
    }

    /// Gradient of [`mass_flow`](Self::mass_flow) with respect to
    /// `(p_a, T_a, p_b, T_b)`: the pressure slopes of
    /// [`mass_flow_derivatives`](Self::mass_flow_derivatives), and the
    /// upstream temperature's through K_T ∝ T_up^(−½) (Eq. 35):
    /// ∂ṁ/∂T_up = −ṁ/(2 T_up).
    pub fn mass_flow_gradient(&self, p_a: f64, t_a: f64, p_b: f64, t_b: f64) -> [f64; 4] {
        let (m, da, db) = self.mass_flow_and_derivatives(p_a, t_a, p_b, t_b);
        let (dta, dtb) = if m > 0.0 {
            (-0.5 * m / t_a, 0.0)
        } else if m < 0.0 {
            (0.0, -0.5 * m / t_b)
        } else {
            (0.0, 0.0)
        };
        [da, dta, db, dtb]
    }

    /// Order of magnitude of the process time of a volume `volume` (m³)
    /// charged or discharged through this restriction, paper Eq. 19:
    /// `O(τ) = V / (γ C p_N)` (s), with `gamma` the heat capacity ratio and
    /// `p_ref` the reference pressure `p_N` (Pa) (usually [`ANR_PRESSURE`]).
    /// Meaningful for positive inputs only (not checked).
    pub fn process_time(&self, volume: f64, gamma: f64, p_ref: f64) -> f64 {
        volume / (gamma * self.c * p_ref)
    }

    /// Unloading time `τ_U = K_T0 V / (γ C p_N)` (s) of a volume `volume`
    /// (m³) initially at temperature `t0` (K), discharging through this
    /// restriction: paper Eq. 36 (de las Heras 2001) solved for `τ_U`, with
    /// `K_T0 = sqrt(T_ref / T0)`. Meaningful for positive inputs only.
    pub fn unloading_time(&self, volume: f64, gamma: f64, p_ref: f64, t0: f64) -> f64 {
        (self.t_ref / t0).sqrt() * self.process_time(volume, gamma, p_ref)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 13.2 L/(min·bar) in m³/(s·Pa): 13.2e-3 m³ / 60 s / 1e5 Pa = 2.2e-9.
    const C_13_2: f64 = 13.2e-3 / 60.0 / 1e5;
    const BAR: f64 = 1e5;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / a.abs().max(b.abs())
    }

    fn fc(b: f64) -> FlowCharacteristic {
        FlowCharacteristic::new(C_13_2, b).unwrap()
    }

    #[test]
    fn defaults_and_getters() {
        let f = fc(0.3);
        assert_eq!(f.c(), C_13_2);
        assert_eq!(f.b(), 0.3);
        assert_eq!(f.m(), 0.5);
        assert_eq!(f.b_lam(), 0.999);
        assert_eq!(f.t_ref(), 293.15);
        assert_eq!(f.rho_ref(), 1.185);
        let g = f.with_subsonic_index(0.7).unwrap().with_laminar_ratio(0.99).unwrap().with_reference(288.15, 1.225).unwrap();
        assert_eq!((g.m(), g.b_lam(), g.t_ref(), g.rho_ref()), (0.7, 0.99, 288.15, 1.225));
    }

    #[test]
    fn flow_and_slopes_together_are_the_separate_numbers_bit_for_bit() {
        let laws = [
            fc(0.3),
            fc(0.0).with_subsonic_index(0.7).unwrap(),
            fc(0.45).with_subsonic_index(1.0).unwrap().with_laminar_ratio(0.99).unwrap(),
            fc(0.2).with_subsonic_index(0.35).unwrap().with_reference(288.15, 1.225).unwrap(),
        ];
        let pressures = [0.0, -1.0, 0.5 * BAR, 0.999 * BAR, 0.9995 * BAR, BAR, 1.0005 * BAR, 2.0 * BAR, 6.0 * BAR, f64::NAN];
        let temperatures = [293.15, 250.0, 0.0, f64::NAN];
        for f in &laws {
            for &pa in &pressures {
                for &pb in &pressures {
                    for &ta in &temperatures {
                        let tb = 310.0;
                        let (m, da, db) = f.mass_flow_and_derivatives(pa, ta, pb, tb);
                        let (ea, eb) = f.mass_flow_derivatives(pa, ta, pb, tb);
                        let e = f.mass_flow(pa, ta, pb, tb);
                        let same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
                        assert!(
                            same(m, e) && same(da, ea) && same(db, eb),
                            "{f:?} p_a {pa} T_a {ta} p_b {pb}: {:?} vs {:?}",
                            (m, da, db),
                            (e, ea, eb)
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn the_laminar_line_follows_the_law_it_continues() {
        // ω is continuous at b_lam whatever m and b_lam (the cached slope is
        // recomputed by every builder that changes them)
        for f in [
            fc(0.3),
            fc(0.3).with_subsonic_index(0.8).unwrap(),
            fc(0.3).with_laminar_ratio(0.95).unwrap().with_subsonic_index(0.3).unwrap(),
        ] {
            let below = f.omega(f.b_lam());
            let above = f.omega(f.b_lam() + 1e-12);
            assert!(rel(below, above) < 1e-8, "{f:?}: {below} vs {above}");
        }
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        assert_eq!(FlowCharacteristic::new(0.0, 0.3), Err(FlowError::Conductance(0.0)));
        assert!(FlowCharacteristic::new(f64::NAN, 0.3).is_err());
        assert!(FlowCharacteristic::new(f64::INFINITY, 0.3).is_err());
        assert_eq!(FlowCharacteristic::new(1e-9, 1.0), Err(FlowError::CriticalRatio(1.0)));
        assert!(FlowCharacteristic::new(1e-9, -0.1).is_err());
        assert!(FlowCharacteristic::new(1e-9, f64::NAN).is_err());
        assert!(matches!(FlowCharacteristic::new(1e-9, 0.9995), Err(FlowError::LaminarRatio { .. })));
        assert!(FlowCharacteristic::new(1e-9, 0.0).is_ok());
        let f = fc(0.3);
        assert!(f.with_subsonic_index(0.0).is_err());
        assert!(f.with_subsonic_index(1.01).is_err());
        assert!(f.with_subsonic_index(1.0).is_ok());
        assert!(f.with_laminar_ratio(0.3).is_err());
        assert!(f.with_laminar_ratio(1.0).is_err());
        assert!(f.with_reference(0.0, 1.185).is_err());
        assert!(f.with_reference(293.15, -1.0).is_err());
        let msg = FlowCharacteristic::new(-1.0, 0.3).unwrap_err().to_string();
        assert_eq!(msg, "C must be > 0 m^3/(s Pa), got -1");
        let msg = f.with_laminar_ratio(0.2).unwrap_err().to_string();
        assert!(msg.starts_with("b_lam must be in (b, 1)"), "{msg}");
    }

    #[test]
    fn choked_hand_value() {
        // C = 13.2 L/(min bar) = 2.2e-9 m³/(s Pa), ρ_ref = 1.185 kg/m³,
        // p1 = 4 bar, p2 = 1 bar → r = 0.25 < b = 0.3 → choked, ω = 1.
        // C ρ p1 = 2.2e-9 · 1.185 · 4e5 = 1.0428e-3 kg/s.
        // K_T = sqrt(293.15/292) = sqrt(1.0039384) = 1.0019672.
        // m = 1.0428e-3 · 1.0019672 = 1.0448514e-3 kg/s.
        let m = fc(0.3).forward_flow(4.0 * BAR, 292.0, 1.0 * BAR);
        assert!(rel(m, 1.044_851_4e-3) < 1e-7, "m = {m}");
        // Choked: independent of the downstream pressure below b·p1.
        let m0 = fc(0.3).forward_flow(4.0 * BAR, 292.0, 0.0);
        assert_eq!(m, m0);
    }

    #[test]
    fn subsonic_and_laminar_hand_values() {
        // b = 0.5, p1 = 5 bar, p2 = 4 bar → r = 0.8, x = 0.3/0.5 = 0.6,
        // 1 − x² = 0.64, ω = sqrt(0.64) = 0.8, T1 = T_ref → K_T = 1.
        // m = 2.2e-9 · 1.185 · 5e5 · 0.8 = 1.0428e-3 kg/s.
        let f = fc(0.5);
        let m = f.forward_flow(5.0 * BAR, 293.15, 4.0 * BAR);
        assert!(rel(m, 1.0428e-3) < 1e-12, "m = {m}");
        // Same point with m = 1: ω = 0.64 → 0.8342400e-3 kg/s.
        let m1 = f.with_subsonic_index(1.0).unwrap().forward_flow(5.0 * BAR, 293.15, 4.0 * BAR);
        assert!(rel(m1, 0.83424e-3) < 1e-12, "m1 = {m1}");
        // Laminar: b = 0.5, b_lam = 0.98 → x = 0.48/0.5 = 0.96,
        // ω(b_lam) = sqrt(1 − 0.9216) = 0.28; at r = 0.99,
        // ω = 0.28 · 0.01/0.02 = 0.14.
        let fl = f.with_laminar_ratio(0.98).unwrap();
        assert!(rel(fl.omega(0.99), 0.14) < 1e-12);
        assert!(rel(fl.omega(0.98), 0.28) < 1e-12);
    }

    #[test]
    fn m_half_equals_eq33() {
        let b = 0.3;
        let f = fc(b);
        // Interior grid of the subsonic region plus r = b_lam itself (the
        // grid's last point may round one ulp past b_lam into the laminar law).
        let grid = (1..1000).map(|i| b + (0.999 - b) * i as f64 / 1000.0);
        for r in grid.chain(std::iter::once(0.999)) {
            let eq33 = (1.0 - ((r - b) / (1.0 - b)).powi(2)).sqrt();
            assert_eq!(f.omega(r), eq33, "r = {r}");
        }
    }

    #[test]
    fn continuity_at_b_and_b_lam() {
        for &(b, m) in &[(0.3, 0.5), (0.52, 0.5), (0.1, 0.8), (0.3, 1.0)] {
            let f = fc(b).with_subsonic_index(m).unwrap();
            let p1 = 6.0 * BAR;
            for &r0 in &[b, f.b_lam()] {
                let eps = 1e-13;
                let left = f.forward_flow(p1, 300.0, p1 * (r0 - eps));
                let at = f.forward_flow(p1, 300.0, p1 * r0);
                let right = f.forward_flow(p1, 300.0, p1 * (r0 + eps));
                assert!(rel(left, right) < 1e-9, "b={b} m={m} r0={r0}");
                assert!(rel(left, at) < 1e-9, "b={b} m={m} r0={r0}");
            }
            // ω at b_lam from the laminar formula equals the subsonic one.
            let x = (f.b_lam() - b) / (1.0 - b);
            let sub = (1.0 - x * x).powf(m);
            assert!(rel(f.omega(f.b_lam()), sub) < 1e-12);
        }
    }

    #[test]
    fn monotone_in_downstream_and_upstream_pressure() {
        for &b in &[0.0, 0.3, 0.52] {
            let f = fc(b).with_laminar_ratio(0.99).unwrap();
            let p1 = 5.0 * BAR;
            let n = 20_000;
            let mut prev = f.forward_flow(p1, 293.15, 0.0);
            for i in 1..=n {
                let p2 = p1 * i as f64 / n as f64;
                let m = f.forward_flow(p1, 293.15, p2);
                if p2 / p1 > b + 1e-12 {
                    assert!(m < prev, "not decreasing at b={b} p2={p2}");
                } else {
                    assert_eq!(m, prev, "choked flow must be flat");
                }
                assert!(m >= 0.0);
                prev = m;
            }
            assert_eq!(prev, 0.0);
            // Increasing in the upstream pressure at fixed downstream.
            let p2 = 2.0 * BAR;
            let mut prev = 0.0;
            for i in 1..=n {
                let p_up = p2 * (1.0 + 4.0 * i as f64 / n as f64);
                let m = f.forward_flow(p_up, 293.15, p2);
                assert!(m > prev, "not increasing at b={b} p1={p_up}");
                prev = m;
            }
        }
    }

    #[test]
    fn antisymmetry_and_direction() {
        let f = fc(0.3).with_subsonic_index(0.7).unwrap();
        let ps = [0.5, 1.0, 2.0, 3.99, 4.0, 4.001, 7.0].map(|x| x * BAR);
        for &pa in &ps {
            for &pb in &ps {
                let ab = f.mass_flow(pa, 280.0, pb, 330.0);
                let ba = f.mass_flow(pb, 330.0, pa, 280.0);
                assert_eq!(ab, -ba);
                assert_eq!(ab > 0.0, pa > pb);
                let (da, db) = f.mass_flow_derivatives(pa, 280.0, pb, 330.0);
                let (db2, da2) = f.mass_flow_derivatives(pb, 330.0, pa, 280.0);
                assert_eq!((da, db), (-da2, -db2));
            }
        }
        // Reverse flow uses the temperature of side b (the upstream side).
        let rev = f.mass_flow(1.0 * BAR, 280.0, 4.0 * BAR, 330.0);
        assert_eq!(rev, -f.forward_flow(4.0 * BAR, 330.0, 1.0 * BAR));
    }

    #[test]
    fn zero_flow_at_equal_pressures_and_guards() {
        let f = fc(0.3);
        assert_eq!(f.mass_flow(3.0 * BAR, 300.0, 3.0 * BAR, 250.0), 0.0);
        assert_eq!(f.forward_flow(3.0 * BAR, 300.0, 3.5 * BAR), 0.0);
        assert_eq!(f.forward_flow(0.0, 300.0, -1.0), 0.0);
        assert_eq!(f.forward_flow(-2.0, 300.0, -3.0), 0.0);
        assert_eq!(f.forward_flow(f64::NAN, 300.0, 1.0), 0.0);
        assert_eq!(f.forward_flow(2.0 * BAR, 0.0, 1.0), 0.0);
        assert_eq!(f.forward_flow(2.0 * BAR, f64::NAN, 1.0), 0.0);
        assert_eq!(f.mass_flow(0.0, 300.0, 0.0, 300.0), 0.0);
        // Negative downstream pressure is vacuum: choked, equal to p2 = 0.
        assert_eq!(f.forward_flow(2.0 * BAR, 300.0, -5.0), f.forward_flow(2.0 * BAR, 300.0, 0.0));
        assert_eq!(f.omega(-1.0), 1.0);
        assert_eq!(f.omega(1.0), 0.0);
        assert_eq!(f.omega(2.0), 0.0);
        assert_eq!(f.omega(f64::NAN), 0.0);
        let (da, db) = f.mass_flow_derivatives(-1.0, 300.0, -1.0, 300.0);
        assert_eq!((da, db), (0.0, 0.0));
    }

    #[test]
    fn laminar_region_is_linear_in_pressure_drop() {
        let f = fc(0.3);
        let p1 = 4.0 * BAR;
        let x = (0.999f64 - 0.3) / 0.7;
        let g = C_13_2 * ANR_DENSITY * (1.0 - x * x).sqrt() / 0.001;
        for dp in [1.0, 10.0, 100.0, 399.0] {
            let m = f.forward_flow(p1, ANR_TEMPERATURE, p1 - dp);
            assert!(rel(m, g * dp) < 1e-9, "dp = {dp}");
        }
        // Slope at equal pressures is the same laminar conductance.
        let (da, db) = f.mass_flow_derivatives(p1, 293.15, p1, 293.15);
        assert!(rel(da, g) < 1e-12 && rel(db, -g) < 1e-12);
    }

    #[test]
    fn temperature_correction() {
        let f = fc(0.3);
        for &(p1, p2) in &[(6.0 * BAR, 1.0 * BAR), (6.0 * BAR, 5.0 * BAR)] {
            let cold = f.forward_flow(p1, 293.15, p2);
            let hot = f.forward_flow(p1, 400.0, p2);
            assert!(hot < cold);
            assert!(rel(hot / cold, (293.15f64 / 400.0).sqrt()) < 1e-14);
        }
        // Changing the reference scales by ρ_ref · sqrt(T_ref).
        let g = f.with_reference(273.15, 1.293).unwrap();
        let ratio = g.forward_flow(6.0 * BAR, 300.0, 1.0 * BAR) / f.forward_flow(6.0 * BAR, 300.0, 1.0 * BAR);
        let expect = 1.293 / 1.185 * (273.15f64 / 293.15).sqrt();
        assert!(rel(ratio, expect) < 1e-14);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for &m in &[0.5, 0.75, 1.0] {
            let f = fc(0.3).with_subsonic_index(m).unwrap().with_laminar_ratio(0.99).unwrap();
            let pa = 5.0 * BAR;
            // Choked, subsonic (several), laminar; both flow directions.
            for &r in &[0.1, 0.25, 0.35, 0.6, 0.9, 0.985, 0.995, 0.9999] {
                for &swap in &[false, true] {
                    let (p_a, p_b) = if swap { (pa * r, pa) } else { (pa, pa * r) };
                    let (ta, tb) = (310.0, 285.0);
                    let (da, db) = f.mass_flow_derivatives(p_a, ta, p_b, tb);
                    let h = 1e-6 * pa;
                    let fd_a = (f.mass_flow(p_a + h, ta, p_b, tb) - f.mass_flow(p_a - h, ta, p_b, tb)) / (2.0 * h);
                    let fd_b = (f.mass_flow(p_a, ta, p_b + h, tb) - f.mass_flow(p_a, ta, p_b - h, tb)) / (2.0 * h);
                    let scale = da.abs().max(db.abs());
                    assert!((da - fd_a).abs() < 1e-6 * scale, "m={m} r={r} swap={swap}: {da} vs {fd_a}");
                    assert!((db - fd_b).abs() < 1e-6 * scale, "m={m} r={r} swap={swap}: {db} vs {fd_b}");
                }
            }
        }
    }

    #[test]
    fn characteristic_times() {
        // V = 1 L, γ = 1.4, C = 2.2e-9, p_N = 1e5:
        // τ = 1e-3 / (1.4 · 2.2e-9 · 1e5) = 1e-3 / 3.08e-4 = 3.2467532 s.
        let f = fc(0.3);
        let tau = f.process_time(1e-3, 1.4, ANR_PRESSURE);
        assert!(rel(tau, 3.246_753_2) < 1e-7, "tau = {tau}");
        // Eq. 36: C = K_T0 V / (γ p_N τ_U) must give back C.
        let t0 = 320.0;
        let tau_u = f.unloading_time(1e-3, 1.4, ANR_PRESSURE, t0);
        let c_back = (ANR_TEMPERATURE / t0).sqrt() * 1e-3 / (1.4 * ANR_PRESSURE * tau_u);
        assert!(rel(c_back, C_13_2) < 1e-14);
    }
}
