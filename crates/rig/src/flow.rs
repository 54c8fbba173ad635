//! Mass flow through restrictions: ISO 6358 (paper Eq. 33–35), the check
//! valve of the speed-control valve, and the laminar seal leak.
//!
//! # ISO 6358 (ISO 6358:1989; paper Eq. 33–35)
//!
//! For a restriction with sonic conductance C [m³/(s Pa)] and critical
//! pressure ratio b, upstream stagnation state (p_u, T_u) and downstream
//! pressure p_d, r = p_d/p_u:
//!
//! ```text
//!   ṁ = C ρ_N p_u √(T_N/T_u) ω(r)                          (Eq. 34, 35)
//!   ω = 1                                   r ≤ b          (choked)
//!   ω = (1 − ((r − b)/(1 − b))²)^m          b < r ≤ 1      (Eq. 33 with m = ½)
//! ```
//!
//! with the reference state of ISO 8778 as used by ISO 6358:
//! ρ_N = 1.185 kg/m³, T_N = 293.15 K. The subsonic index m defaults to ½
//! (the paper's ellipse); other values are the ISO 6358-2:2013
//! generalisation.
//!
//! **Laminar end region (optional).** The ellipse has an unbounded slope
//! ∂ṁ/∂p_d as r → 1, which makes the equations stiff near equilibrium. With
//! a width w (ISO 6358-2:2013 uses w = 10⁻³, i.e. r > 0.999), ω is replaced
//! for r > 1 − w by the straight line through ω(1 − w) and 0 at r = 1:
//! ω = ω(1 − w)·(1 − r)/w, so ṁ is proportional to p_u − p_d there (a
//! viscous, Poiseuille-like region). ṁ stays continuous at r = 1 − w (its
//! slope jumps: the line is the chord, not the tangent). The default is the
//! pure ellipse, as in the paper.
//!
//! # Check valve
//!
//! A one-way ISO 6358 restriction (C_ck, b_ck) that passes flow only from
//! its inlet to its outlet, opening at the cracking pressure Δp_cr. Two laws:
//! * **exact** (default): open iff p_in − p_out > Δp_cr, then the full
//!   ISO 6358 flow; shut below. With Δp_cr = 0 the flow is continuous (it
//!   vanishes with the pressure difference) but its slope is not. With
//!   Δp_cr > 0 it jumps at the cracking pressure, and at exactly
//!   p_in − p_out = Δp_cr the ideal valve may take any opening between shut
//!   and open (an ideal poppet without spring stiffness): where it feeds a
//!   volume-less junction that neither opening balances, it floats there
//!   (`model`, `Plant::fill_junction`);
//! * **linear opening** over Δp_o: the conductance is scaled by
//!   s = clamp((p_in − p_out − Δp_cr)/Δp_o, 0, 1), so the valve opens
//!   gradually (a spring-loaded poppet with a finite stiffness).
//!
//! # Seal leak between the chambers (hidden effect)
//!
//! Either an ISO 6358 restriction, or a laminar capillary: isothermal
//! compressible Hagen–Poiseuille flow, ṁ = k (p_u² − p_d²)/(2 R T_u), where
//! for a capillary of diameter d and length ℓ, k = π d⁴/(128 μ ℓ) [m³/(s Pa)].
//! (Integrate −dp/dx = 128 μ ṁ/(π d⁴ ρ) with ρ = p/(R T) along ℓ.)
//! Or the linear law of most pneumatics textbooks for internal leakage,
//! ṁ = k_L (p_u − p_d) with a constant leakage coefficient k_L [kg/(s Pa)]
//! (e.g. P. Beater, "Pneumatic Drives", Springer 2007, §4; Richer &
//! Hurmuzlu, J. Dyn. Sys. Meas. Control 122 (2000) 416): the mass flow does
//! not grow with the mean pressure and never chokes.

use crate::error::RigError;

/// Density of air at the ISO 6358 reference state [kg/m³].
pub const RHO_N: f64 = 1.185;
/// Temperature of the ISO 6358 reference state [K].
pub const T_N: f64 = 293.15;
/// 1 L/(min·bar) expressed in m³/(s·Pa).
pub const LPM_PER_BAR: f64 = 1e-3 / 60.0 / 1e5;

/// The shape of the ISO 6358 characteristic in the subsonic range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubsonicLaw {
    /// Subsonic index m (½ for the paper's ellipse, Eq. 33).
    pub index: f64,
    /// Width w of the laminar end region r ∈ (1 − w, 1], or `None` for the
    /// pure characteristic down to r = 1.
    pub laminar_width: Option<f64>,
}

impl Default for SubsonicLaw {
    fn default() -> Self {
        SubsonicLaw { index: 0.5, laminar_width: None }
    }
}

impl SubsonicLaw {
    pub(crate) fn validate(&self) -> Result<(), RigError> {
        if !(self.index > 0.0 && self.index <= 2.0) {
            return Err(RigError::invalid("form.subsonic.index", self.index, "must lie in (0, 2]"));
        }
        if let Some(w) = self.laminar_width {
            if !(w > 0.0 && w < 0.5) {
                return Err(RigError::invalid("form.subsonic.laminar_width", w, "must lie in (0, 0.5)"));
            }
        }
        Ok(())
    }

    /// The flow function ω(r) for critical ratio b (the characteristic
    /// normalised by its choked value).
    pub fn omega(&self, r: f64, b: f64) -> f64 {
        if r <= b {
            return 1.0;
        }
        if r >= 1.0 {
            return 0.0;
        }
        if let Some(w) = self.laminar_width {
            let r_lam = 1.0 - w;
            if r > r_lam && r_lam > b {
                return self.ellipse(r_lam, b) * (1.0 - r) / w;
            }
        }
        self.ellipse(r, b)
    }

    fn ellipse(&self, r: f64, b: f64) -> f64 {
        let q = (r - b) / (1.0 - b);
        let base = (1.0 - q * q).max(0.0);
        if self.index == 0.5 {
            base.sqrt()
        } else {
            base.powf(self.index)
        }
    }
}

/// An ISO 6358 restriction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Restriction {
    /// Sonic conductance C [m³/(s Pa)].
    pub c: f64,
    /// Critical pressure ratio b.
    pub b: f64,
}

impl Restriction {
    /// From C in L/(min·bar).
    pub fn lpm_per_bar(c: f64, b: f64) -> Self {
        Restriction { c: c * LPM_PER_BAR, b }
    }

    pub(crate) fn validate(&self, name: &str) -> Result<(), RigError> {
        if !(self.c >= 0.0 && self.c.is_finite()) {
            return Err(RigError::invalid(&format!("{name}.c"), self.c, "must be non-negative and finite"));
        }
        if !(self.b >= 0.0 && self.b < 1.0) {
            return Err(RigError::invalid(&format!("{name}.b"), self.b, "must lie in [0, 1)"));
        }
        Ok(())
    }

    /// Mass flow [kg/s] from an upstream state (p_u, T_u) to a downstream
    /// pressure p_d with p_u ≥ p_d (zero otherwise). Paper Eq. 34.
    pub fn forward(&self, law: &SubsonicLaw, p_u: f64, t_u: f64, p_d: f64) -> f64 {
        if p_u <= p_d || self.c == 0.0 {
            return 0.0;
        }
        self.c * RHO_N * p_u * (T_N / t_u).sqrt() * law.omega(p_d / p_u, self.b)
    }
}

/// The check-valve law.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum CheckLaw {
    /// Open iff p_in − p_out exceeds the cracking pressure.
    #[default]
    Exact,
    /// Conductance rises linearly from 0 to full over this pressure range [Pa]
    /// above the cracking pressure.
    Linear {
        /// Opening range Δp_o [Pa].
        opening: f64,
    },
}

impl CheckLaw {
    pub(crate) fn validate(&self) -> Result<(), RigError> {
        if let CheckLaw::Linear { opening } = *self {
            if !(opening > 0.0 && opening.is_finite()) {
                return Err(RigError::invalid("form.check.opening", opening, "must be positive and finite"));
            }
        }
        Ok(())
    }

    /// Opening fraction in [0, 1] for a pressure difference `dp` = p_in − p_out.
    pub fn opening(&self, dp: f64, cracking: f64) -> f64 {
        let over = dp - cracking;
        match *self {
            CheckLaw::Exact => {
                if over > 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            CheckLaw::Linear { opening } => (over / opening).clamp(0.0, 1.0),
        }
    }
}

/// A leak between the two chambers across the piston seal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LeakLaw {
    /// ISO 6358 restriction (bidirectional, upstream is the higher pressure).
    Iso(Restriction),
    /// Laminar capillary: ṁ = k (p_u² − p_d²)/(2 R T_u), k [m³/(s Pa)].
    Laminar {
        /// Laminar coefficient k = π d⁴/(128 μ ℓ) [m³/(s Pa)].
        k: f64,
    },
    /// Linear in the pressure difference: ṁ = k_l (p_u − p_d), k_l [kg/(s Pa)].
    Linear {
        /// Leakage coefficient [kg/(s Pa)].
        k_l: f64,
    },
}

impl LeakLaw {
    pub(crate) fn validate(&self) -> Result<(), RigError> {
        match *self {
            LeakLaw::Iso(r) => r.validate("effects.seal_leak"),
            LeakLaw::Laminar { k } | LeakLaw::Linear { k_l: k } => {
                if !(k >= 0.0 && k.is_finite()) {
                    return Err(RigError::invalid("effects.seal_leak.k", k, "must be non-negative and finite"));
                }
                Ok(())
            }
        }
    }

    /// Mass flow from upstream (p_u, T_u) to p_d ≤ p_u [kg/s].
    pub fn forward(&self, law: &SubsonicLaw, gas_r: f64, p_u: f64, t_u: f64, p_d: f64) -> f64 {
        if p_u <= p_d {
            return 0.0;
        }
        match *self {
            LeakLaw::Iso(r) => r.forward(law, p_u, t_u, p_d),
            LeakLaw::Laminar { k } => k * (p_u * p_u - p_d * p_d) / (2.0 * gas_r * t_u),
            LeakLaw::Linear { k_l } => k_l * (p_u - p_d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_choked_flow() {
        // C = 13.2 L/(min bar) at 4 bar, 292 K, choked:
        // 13.2/6e9 · 1.185 · 4e5 · √(293.15/292) = 1.04485e-3 kg/s
        let r = Restriction::lpm_per_bar(13.2, 0.3);
        let m = r.forward(&SubsonicLaw::default(), 4e5, 292.0, 1e5);
        let expect = 13.2 / 6e9 * 1.185 * 4e5 * (293.15f64 / 292.0).sqrt();
        assert!((m - expect).abs() < 1e-15);
        assert!((m - 1.0448514e-3).abs() < 1e-9, "{m}");
    }

    #[test]
    fn ellipse_is_continuous_and_monotone() {
        let law = SubsonicLaw::default();
        let b = 0.3;
        assert_eq!(law.omega(b, b), 1.0);
        assert!((law.omega(b + 1e-9, b) - 1.0).abs() < 1e-12);
        assert_eq!(law.omega(1.0, b), 0.0);
        let mut last = 1.0;
        for i in 0..=1000 {
            let r = b + (1.0 - b) * i as f64 / 1000.0;
            let w = law.omega(r, b);
            assert!(w <= last + 1e-15);
            last = w;
        }
        // midpoint of the ellipse by hand: q = 0.5 → √0.75
        assert!((law.omega(0.65, 0.3) - 0.75f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn laminar_end_region_is_linear_and_continuous() {
        let law = SubsonicLaw { index: 0.5, laminar_width: Some(1e-3) };
        let b = 0.3;
        let at = law.omega(0.999, b);
        assert!((at - SubsonicLaw::default().omega(0.999, b)).abs() < 1e-15);
        assert!((law.omega(0.9995, b) - 0.5 * at).abs() < 1e-12);
        // the pure ellipse is much steeper near r = 1
        assert!(SubsonicLaw::default().omega(0.9999, b) > 2.0 * law.omega(0.9999, b));
    }

    #[test]
    fn subsonic_index() {
        let law = SubsonicLaw { index: 0.6, laminar_width: None };
        assert!((law.omega(0.65, 0.3) - 0.75f64.powf(0.6)).abs() < 1e-15);
    }

    #[test]
    fn check_valve_laws() {
        assert_eq!(CheckLaw::Exact.opening(1.0, 0.0), 1.0);
        assert_eq!(CheckLaw::Exact.opening(-1.0, 0.0), 0.0);
        assert_eq!(CheckLaw::Exact.opening(0.0, 0.0), 0.0);
        let lin = CheckLaw::Linear { opening: 1000.0 };
        assert_eq!(lin.opening(500.0, 0.0), 0.5);
        assert_eq!(lin.opening(5000.0, 0.0), 1.0);
        assert_eq!(lin.opening(600.0, 100.0), 0.5);
    }

    #[test]
    fn linear_leak_by_hand() {
        let law = LeakLaw::Linear { k_l: 2e-11 };
        let m = law.forward(&SubsonicLaw::default(), 287.05, 4e5, 292.0, 1e5);
        assert_eq!(m, 2e-11 * 3e5);
        // the same drop at a higher mean pressure passes the same flow
        assert_eq!(law.forward(&SubsonicLaw::default(), 287.05, 7e5, 292.0, 4e5), m);
        assert_eq!(law.forward(&SubsonicLaw::default(), 287.05, 1e5, 292.0, 4e5), 0.0);
    }

    #[test]
    fn laminar_leak_by_hand() {
        let k = 1e-12;
        let m = LeakLaw::Laminar { k }.forward(&SubsonicLaw::default(), 287.05, 4e5, 292.0, 1e5);
        assert!((m - k * (16e10 - 1e10) / (2.0 * 287.05 * 292.0)).abs() < 1e-20);
    }
}
