//! Piston friction: the paper's pressure-dependent law (Eq. 37) with a
//! stick–slip model after Karnopp (1985) and optional Stribeck decay.
//!
//! Sliding (paper Eq. 37, with the viscous coefficient clipped at zero):
//!
//! ```text
//!   F_c = k0 + k1 (p1 + p2)                         Coulomb level
//!   c   = max(0, k2 + k3 (p1 − k4 p2))              viscous coefficient
//!   F_f = sgn(v) [F_c + (r − 1) F_c φ(|v|/v_s)] + c v
//! ```
//!
//! r ≥ 1 is the breakaway ratio and φ the Stribeck decay (exponential
//! φ(z) = e^(−z) or Gaussian φ(z) = e^(−z²)); without a Stribeck velocity
//! φ ≡ 0, so for r > 1 the friction drops from the static level r F_c to
//! F_c the instant the piston moves (classical static/kinetic friction).
//!
//! Sticking (D. Karnopp, "Computer simulation of stick-slip friction in
//! mechanical dynamic systems", J. Dyn. Sys., Meas., Control 107 (1985)
//! 100–103): while the piston is at rest, friction balances the applied
//! force as long as |F_applied| does not exceed the breakaway level
//! F_s = r F_c. Karnopp implements this with a small velocity band; here the
//! stuck state is a mode of its own (v ≡ 0 exactly) left by a located event
//! when |F_applied| reaches F_s, and entered when the velocity crosses zero
//! with |F_applied| < F_s (see `sim`). At an end stop the stop itself
//! carries any force pushing into it.

use crate::error::RigError;

/// Coefficients of paper Eq. 37.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eq37 {
    /// Constant Coulomb part k0 [N].
    pub k0: f64,
    /// Pressure dependence of the Coulomb part k1 [N/Pa].
    pub k1: f64,
    /// Viscous coefficient k2 [N s/m].
    pub k2: f64,
    /// Pressure dependence of the viscous coefficient k3 [N s/(m Pa)].
    pub k3: f64,
    /// Weight of the rod-chamber pressure in the viscous term k4 [-].
    pub k4: f64,
}

impl Eq37 {
    /// The values of models/meter_out.json.
    pub fn paper() -> Self {
        Eq37 { k0: 10.0, k1: 2e-5, k2: 50.0, k3: 2e-4, k4: 0.9 }
    }

    pub(crate) fn validate(&self) -> Result<(), RigError> {
        for (n, v) in [("k0", self.k0), ("k1", self.k1), ("k2", self.k2), ("k3", self.k3), ("k4", self.k4)] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(RigError::invalid(&format!("rig.friction.{n}"), v, "must be non-negative and finite"));
            }
        }
        Ok(())
    }

    /// Coulomb level F_c [N].
    pub fn coulomb(&self, p1: f64, p2: f64) -> f64 {
        self.k0 + self.k1 * (p1 + p2)
    }

    /// Viscous coefficient, clipped at zero [N s/m].
    pub fn viscous(&self, p1: f64, p2: f64) -> f64 {
        (self.k2 + self.k3 * (p1 - self.k4 * p2)).max(0.0)
    }
}

/// Shape of the Stribeck decay φ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StribeckShape {
    /// φ(z) = e^(−z).
    Exponential,
    /// φ(z) = e^(−z²).
    Gaussian,
}

/// Stribeck decay of the static excess towards the Coulomb level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stribeck {
    /// Stribeck velocity v_s [m/s] (> 0).
    pub velocity: f64,
    /// Shape of the decay.
    pub shape: StribeckShape,
}

/// The friction variant: breakaway ratio and optional Stribeck decay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionVariant {
    /// Breakaway ratio r = F_s/F_c ≥ 1.
    pub breakaway_ratio: f64,
    /// Stribeck decay, or `None` for an immediate drop to F_c.
    pub stribeck: Option<Stribeck>,
}

impl Default for FrictionVariant {
    fn default() -> Self {
        FrictionVariant { breakaway_ratio: 1.0, stribeck: None }
    }
}

impl FrictionVariant {
    pub(crate) fn validate(&self, name: &str) -> Result<(), RigError> {
        if !(self.breakaway_ratio >= 1.0 && self.breakaway_ratio.is_finite()) {
            return Err(RigError::invalid(&format!("{name}.breakaway_ratio"), self.breakaway_ratio, "must be ≥ 1 and finite"));
        }
        if let Some(s) = self.stribeck {
            if !(s.velocity > 0.0 && s.velocity.is_finite()) {
                return Err(RigError::invalid(&format!("{name}.stribeck.velocity"), s.velocity, "must be positive and finite"));
            }
        }
        Ok(())
    }

    /// Breakaway (static) level F_s = r F_c [N].
    pub fn breakaway(&self, law: &Eq37, p1: f64, p2: f64) -> f64 {
        self.breakaway_ratio * law.coulomb(p1, p2)
    }

    /// Friction force opposing sliding in direction `dir` (±1) at speed
    /// `speed` = dir·v ≥ 0, excluding the viscous term [N, magnitude].
    pub fn dry(&self, law: &Eq37, p1: f64, p2: f64, speed: f64) -> f64 {
        let fc = law.coulomb(p1, p2);
        let phi = match self.stribeck {
            None => 0.0,
            Some(s) => {
                let z = speed.max(0.0) / s.velocity;
                match s.shape {
                    StribeckShape::Exponential => (-z).exp(),
                    StribeckShape::Gaussian => (-z * z).exp(),
                }
            }
        };
        fc * (1.0 + (self.breakaway_ratio - 1.0) * phi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq37_by_hand() {
        let f = Eq37::paper();
        assert_eq!(f.coulomb(4e5, 4e5), 10.0 + 2e-5 * 8e5);
        assert!((f.viscous(4e5, 1e5) - (50.0 + 2e-4 * (4e5 - 0.9e5))).abs() < 1e-9);
        // clipped: p1 low, p2 high
        assert_eq!(f.viscous(0.98e5, 4e5), 0.0);
    }

    #[test]
    fn stribeck_starts_at_breakaway_and_decays_to_coulomb() {
        let law = Eq37::paper();
        for shape in [StribeckShape::Exponential, StribeckShape::Gaussian] {
            let v = FrictionVariant { breakaway_ratio: 2.5, stribeck: Some(Stribeck { velocity: 5e-3, shape }) };
            let fs = v.breakaway(&law, 3e5, 4e5);
            assert!((v.dry(&law, 3e5, 4e5, 0.0) - fs).abs() < 1e-12);
            assert!((v.dry(&law, 3e5, 4e5, 1.0) - law.coulomb(3e5, 4e5)).abs() < 1e-9);
        }
        let plain = FrictionVariant { breakaway_ratio: 2.0, stribeck: None };
        assert_eq!(plain.dry(&law, 1e5, 1e5, 0.0), law.coulomb(1e5, 1e5));
    }
}
