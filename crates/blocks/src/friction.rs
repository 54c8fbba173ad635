//! Friction: pressure-dependent seal friction of a cylinder (paper Eq. 37),
//! with stick–slip after Karnopp (1985) and an optional Stribeck term.
//!
//! # Ports
//! - `rod` — mechanical, force: acts on the piston node.
//! - `p1`, `p2` — signal inputs: head-side and rod-side chamber pressures [Pa].
//!
//! # Parameters (defaults in brackets)
//! - `k0` [N, 0], `k1` [N/Pa, 0]: Coulomb level F_c = k0 + k1·(p1 + p2).
//! - `k2` [N s/m, 0], `k3` [N s/(m Pa), 0], `k4` [-, 1]: viscous coefficient
//!   c = k2 + k3·(p1 − k4·p2).
//! - `breakaway_ratio` [-, 1]: static (breakaway) level F_s = ratio·F_c; 1 gives
//!   the paper's model (breakaway equal to the Coulomb level).
//! - `stribeck_velocity` [m/s, 0]: v_s of the Stribeck decay; 0 disables it.
//!
//! # Equations
//! Sliding force magnitude at speed |v| (paper Eq. 37 plus Stribeck):
//! F_f(v) = F_c + (F_s − F_c)·exp(−(|v|/v_s)²) + max(c, 0)·|v|,
//! applied against the motion; computed as F_s − (F_s − F_c)·(1 − exp(…)) so
//! that F_f(0) is F_s to the last bit (a node breaking away at F = F_s must
//! not start backwards by a rounding error). Without Stribeck (v_s = 0) the sliding level is
//! F_c + c|v| and F_s is only the level to break away from rest.
//! Stick–slip (Karnopp 1985), implemented by the mechanical node logic in
//! `solve`: while stuck, the friction balances the other forces exactly as
//! long as |ΣF| ≤ F_s, so a stuck piston holds with no creep; it breaks away
//! when |ΣF| exceeds F_s.
//!
//! # Assumptions
//! The viscous coefficient is clipped at zero: for rod-side pressures well
//! above the head side, Eq. 37 with the paper's k3, k4 would give a negative
//! slope, which would feed energy into the motion.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("k0", dim::FORCE, Some(0.0), Range::NonNegative, "N", "Coulomb level at zero pressure"),
    ParamSpec::quantity("k1", dim::FORCE_PER_PRESSURE, Some(0.0), Range::NonNegative, "N/Pa", "Coulomb level per (p1 + p2)"),
    ParamSpec::quantity("k2", dim::DAMPING, Some(0.0), Range::NonNegative, "N s/m", "viscous coefficient at zero pressure"),
    ParamSpec::quantity("k3", dim::DAMPING_PER_PRESSURE, Some(0.0), Range::Any, "N s/(m Pa)", "viscous coefficient per (p1 - k4 p2)"),
    ParamSpec::quantity("k4", dim::DIMENSIONLESS, Some(1.0), Range::Any, "", "weight of p2 in the viscous term"),
    ParamSpec::quantity("breakaway_ratio", dim::DIMENSIONLESS, Some(1.0), Range::Closed(1.0, 10.0), "", "breakaway level / Coulomb level"),
    ParamSpec::quantity(
        "stribeck_velocity",
        dim::VELOCITY,
        Some(0.0),
        Range::NonNegative,
        "m/s",
        "Stribeck velocity (0 = no Stribeck decay)",
    ),
];

pub const PORTS: &[PortSpec] = &[
    PortSpec::new("rod", PortKind::MechanicalForce, "friction on the piston node"),
    PortSpec::signal("p1", PortKind::SignalIn, "Pa", "head-side pressure"),
    PortSpec::signal("p2", PortKind::SignalIn, "Pa", "rod-side pressure"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "F_coulomb", unit: "N" }, OutputSpec { name: "F_sliding", unit: "N" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Friction {
    pub k0: f64,
    pub k1: f64,
    pub k2: f64,
    pub k3: f64,
    pub k4: f64,
    pub breakaway_ratio: f64,
    pub stribeck_velocity: f64,
}

impl Friction {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        Ok(Friction {
            k0: p.get("k0"),
            k1: p.get("k1"),
            k2: p.get("k2"),
            k3: p.get("k3"),
            k4: p.get("k4"),
            breakaway_ratio: p.get("breakaway_ratio"),
            stribeck_velocity: p.get("stribeck_velocity"),
        })
    }
    /// Coulomb level F_c = k0 + k1 (p1 + p2) [N].
    pub fn coulomb(&self, p1: f64, p2: f64) -> f64 {
        (self.k0 + self.k1 * (p1 + p2)).max(0.0)
    }
    /// Viscous coefficient c = max(k2 + k3 (p1 − k4 p2), 0) [N s/m].
    pub fn viscous(&self, p1: f64, p2: f64) -> f64 {
        (self.k2 + self.k3 * (p1 - self.k4 * p2)).max(0.0)
    }
    /// Breakaway level F_s [N].
    pub fn breakaway(&self, p1: f64, p2: f64) -> f64 {
        self.breakaway_ratio * self.coulomb(p1, p2)
    }
    /// Sliding friction magnitude at speed |v| [N].
    pub fn sliding(&self, v: f64, p1: f64, p2: f64) -> f64 {
        let fc = self.coulomb(p1, p2);
        let dry = if self.stribeck_velocity > 0.0 {
            let fs = self.breakaway(p1, p2);
            // 1 − exp(−u) as −expm1(−u): exactly 0 at v = 0
            fs + (fs - fc) * (-(v / self.stribeck_velocity).powi(2)).exp_m1()
        } else {
            fc
        };
        dry + self.viscous(p1, p2) * v.abs()
    }
    /// Partials of (sliding, breakaway, viscous) with respect to (v, p1, p2).
    pub fn level_partials(&self, v: f64, p1: f64, p2: f64) -> [[f64; 3]; 3] {
        let fc_on = self.k0 + self.k1 * (p1 + p2) > 0.0;
        let dfc = if fc_on { [0.0, self.k1, self.k1] } else { [0.0; 3] };
        let c_on = self.k2 + self.k3 * (p1 - self.k4 * p2) > 0.0;
        let dc = if c_on { [0.0, self.k3, -self.k3 * self.k4] } else { [0.0; 3] };
        let dfs = dfc.map(|x| self.breakaway_ratio * x);
        let c = self.viscous(p1, p2);
        let sign = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        let mut sliding = [0.0; 3];
        if self.stribeck_velocity > 0.0 {
            // fs + (fs − fc)(e^(−u²) − 1), u = v/v_s
            let u = v / self.stribeck_velocity;
            let e = (-u * u).exp_m1();
            let gap = self.breakaway(p1, p2) - self.coulomb(p1, p2);
            for i in 0..3 {
                sliding[i] = dfs[i] + (dfs[i] - dfc[i]) * e;
            }
            sliding[0] += gap * (e + 1.0) * (-2.0 * u / self.stribeck_velocity);
        } else {
            sliding = dfc;
        }
        for i in 0..3 {
            sliding[i] += dc[i] * v.abs();
        }
        sliding[0] += c * sign;
        [sliding, dfs, dc]
    }
    /// Signed friction force on a node sliding at velocity v ≠ 0 (opposes motion) [N].
    pub fn sliding_force(&self, v: f64, p1: f64, p2: f64) -> f64 {
        -v.signum() * self.sliding(v, p1, p2)
    }
}

impl Block for Friction {
    fn type_name(&self) -> &'static str {
        "friction"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn forces(&self, ctx: &Ctx, out: &mut [PortForce]) {
        let (p1, p2) = (ctx.signals[0], ctx.signals[1]);
        let v = ctx.mechanical[0].v;
        out[0] = PortForce {
            applied: 0.0,
            friction: Some(DryFriction {
                sliding: self.sliding(v, p1, p2),
                breakaway: self.breakaway(p1, p2),
                viscous: self.viscous(p1, p2),
            }),
        };
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        if phase == Phase::Forces {
            let [sliding, breakaway, viscous] = self.level_partials(ctx.mechanical[0].v, ctx.signals[0], ctx.signals[1]);
            for (out, row) in [(Out::Sliding(0), sliding), (Out::Breakaway(0), breakaway), (Out::Viscous(0), viscous)] {
                d.set(out, In::V(0), row[0]);
                d.set(out, In::Signal(0), row[1]);
                d.set(out, In::Signal(1), row[2]);
            }
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        let (p1, p2) = (ctx.signals[0], ctx.signals[1]);
        out[0] = Some(self.coulomb(p1, p2));
        out[1] = Some(self.sliding(ctx.mechanical[0].v, p1, p2));
    }
}

/// Karnopp (1985) decision for a node at rest: does the applied force break it away?
///
/// Returns the direction of motion (+1/−1) if |F| exceeds the breakaway level,
/// or `None` if the node stays stuck (friction balances F exactly).
pub fn breaks_away(applied: f64, breakaway: f64) -> Option<f64> {
    if applied.abs() > breakaway {
        Some(applied.signum())
    } else {
        None
    }
}

/// Registry entry of `friction`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "friction",
    family: crate::registry::Family::Mechanics,
    doc: "seal friction, Eq. 37, stick-slip (Karnopp 1985)",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Friction::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> Friction {
        // Values from models/meter_out.json (issue "Netlists...", Table 2 fit).
        Friction { k0: 10.0, k1: 2e-5, k2: 50.0, k3: 2e-4, k4: 0.9, breakaway_ratio: 1.0, stribeck_velocity: 0.0 }
    }

    #[test]
    fn eq37_by_hand() {
        let f = paper();
        let (p1, p2) = (4e5, 2e5);
        // F_c = 10 + 2e-5 * 6e5 = 22 N; c = 50 + 2e-4 (4e5 - 0.9*2e5) = 50 + 44 = 94 N s/m
        assert!((f.coulomb(p1, p2) - 22.0).abs() < 1e-12);
        assert!((f.viscous(p1, p2) - 94.0).abs() < 1e-9);
        assert!((f.sliding(0.5, p1, p2) - (22.0 + 47.0)).abs() < 1e-9);
    }

    #[test]
    fn viscous_force_opposes_motion() {
        let f = paper();
        for v in [0.3, -0.3, 1e-6, -2.0] {
            let force = f.sliding_force(v, 4e5, 1e5);
            assert!(force * v < 0.0, "v = {v}: F = {force}");
        }
        // the viscous part grows with speed in both directions
        assert!(f.sliding(1.0, 4e5, 1e5) > f.sliding(0.1, 4e5, 1e5));
        assert!(f.sliding(-1.0, 4e5, 1e5) > f.sliding(-0.1, 4e5, 1e5));
    }

    #[test]
    fn holds_below_breakaway_and_breaks_above() {
        let f = paper();
        let fs = f.breakaway(1e5, 1e5); // 14 N
        assert!((fs - 14.0).abs() < 1e-12);
        assert_eq!(breaks_away(13.9, fs), None);
        assert_eq!(breaks_away(-13.9, fs), None);
        assert_eq!(breaks_away(14.1, fs), Some(1.0));
        assert_eq!(breaks_away(-14.1, fs), Some(-1.0));
    }

    #[test]
    fn stribeck_decays_from_breakaway_to_coulomb() {
        let mut f = paper();
        f.breakaway_ratio = 1.5;
        f.stribeck_velocity = 0.01;
        f.k2 = 0.0;
        f.k3 = 0.0;
        let (fc, fs) = (f.coulomb(1e5, 1e5), f.breakaway(1e5, 1e5));
        assert_eq!(f.sliding(0.0, 1e5, 1e5), fs, "exactly the breakaway level at rest");
        assert!((f.sliding(0.1, 1e5, 1e5) - fc).abs() < 1e-9 * fc);
        assert!(f.sliding(0.005, 1e5, 1e5) < fs && f.sliding(0.005, 1e5, 1e5) > fc);
    }

    #[test]
    fn negative_viscous_slope_is_clipped() {
        let f = paper();
        // p2 much larger than p1: k2 + k3 (p1 - 0.9 p2) = 50 + 2e-4 (1e5 - 6.3e5) < 0
        assert_eq!(f.viscous(1e5, 7e5), 0.0);
    }
}
