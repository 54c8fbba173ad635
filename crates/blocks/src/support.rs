//! Small helpers shared by several blocks (not a block): opening laws,
//! on/off thresholds with hysteresis, table interpolation, names of ports
//! made from parameters, and how density and enthalpy of a gas state move
//! with its pressure and temperature (for exact partial derivatives).

use std::collections::BTreeSet;
use std::sync::{Mutex, OnceLock};

/// How the density and enthalpy of a gas state (p, T) move with p and T,
/// from the gas model's first derivatives in (ρ, T) (no differences):
/// ∂ρ/∂p = 1/p_ρ, ∂ρ/∂T = −p_T/p_ρ, and with h_ρ = p_ρ/ρ − T p_T/ρ²,
/// h_T = c_v + p_T/ρ: ∂h/∂p = h_ρ ∂ρ/∂p, ∂h/∂T = h_T + h_ρ ∂ρ/∂T (= c_p).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GasSlopes {
    pub drho_dp: f64,
    pub drho_dt: f64,
    pub dh_dp: f64,
    pub dh_dt: f64,
}

impl GasSlopes {
    pub fn at(gas: &dyn gas::GasModel, s: &gas::GasState) -> GasSlopes {
        let (rho, t) = (s.rho, s.t);
        let p_rho = gas.dp_drho(rho, t);
        let p_t = gas.t_dp_dt(rho, t) / t;
        let (h_rho, h_t) = enthalpy_slopes(gas, rho, t);
        let drho_dp = 1.0 / p_rho;
        let drho_dt = -p_t / p_rho;
        GasSlopes { drho_dp, drho_dt, dh_dp: h_rho * drho_dp, dh_dt: h_t + h_rho * drho_dt }
    }
}

/// (∂h/∂ρ at constant T, ∂h/∂T at constant ρ) of a gas model at (ρ, T).
pub fn enthalpy_slopes(gas: &dyn gas::GasModel, rho: f64, t: f64) -> (f64, f64) {
    let p_rho = gas.dp_drho(rho, t);
    let p_t = gas.t_dp_dt(rho, t) / t;
    (p_rho / rho - t * p_t / (rho * rho), gas.cv(rho, t) + p_t / rho)
}

/// Linear opening law: 0 below `start`, 1 above `start + band`, linear in
/// between (`band` > 0). Continuous, so a valve whose opening follows a
/// pressure difference does not make the flow jump.
pub fn ramp(x: f64, start: f64, band: f64) -> f64 {
    if band > 0.0 {
        ((x - start) / band).clamp(0.0, 1.0)
    } else if x > start {
        1.0
    } else {
        0.0
    }
}

/// Slope d/dx of [`ramp`]: 1/band inside the band, 0 outside (and for a step).
pub fn ramp_slope(x: f64, start: f64, band: f64) -> f64 {
    let u = (x - start) / band;
    if band > 0.0 && u > 0.0 && u < 1.0 {
        1.0 / band
    } else {
        0.0
    }
}

/// Level above which an on/off signal switches on, and below which it
/// switches off again: 0.5 ± [`HYSTERESIS`]/2 (a 0/1 command crosses both at once).
pub const ON_LEVEL: f64 = 0.55;
pub const OFF_LEVEL: f64 = 0.45;
/// Width of the band between [`OFF_LEVEL`] and [`ON_LEVEL`].
pub const HYSTERESIS: f64 = ON_LEVEL - OFF_LEVEL;

/// Root function of an on/off input with hysteresis, negative while the
/// accepted state `on` stands: off → u − ON_LEVEL, on → OFF_LEVEL − u.
pub fn switch_root(on: bool, u: f64) -> f64 {
    if on {
        OFF_LEVEL - u
    } else {
        u - ON_LEVEL
    }
}

/// The on/off state an input holds after `switch_root` fired (or at rest):
/// on above [`ON_LEVEL`], off below [`OFF_LEVEL`], unchanged in between.
pub fn switch_state(on: bool, u: f64) -> bool {
    if u > ON_LEVEL {
        true
    } else if u < OFF_LEVEL {
        false
    } else {
        on
    }
}

/// Slope d/dx of [`interpolate`] at x: the slope of the segment that
/// `interpolate` uses there, 0 beyond the table's ends.
pub fn interpolate_slope(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    match xs.iter().position(|&xi| xi > x) {
        None | Some(0) => 0.0,
        Some(i) => (ys[i] - ys[i - 1]) / (xs[i] - xs[i - 1]),
    }
}

/// Piecewise-linear interpolation in a table with increasing `xs`, held
/// constant beyond its ends. Empty table: 0.
pub fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    match xs.iter().position(|&xi| xi > x) {
        None => ys.last().copied().unwrap_or(0.0),
        Some(0) => ys.first().copied().unwrap_or(0.0),
        Some(i) => {
            let (x0, x1, y0, y1) = (xs[i - 1], xs[i], ys[i - 1], ys[i]);
            y0 + (y1 - y0) * (x - x0) / (x1 - x0)
        }
    }
}

/// A name made at run time (a sequencer's port named in its parameters) as
/// a `&'static str`, stored once per distinct text for the life of the
/// program, so that building many circuits does not keep allocating.
pub fn intern(name: &str) -> &'static str {
    static NAMES: OnceLock<Mutex<BTreeSet<&'static str>>> = OnceLock::new();
    let mut names = NAMES.get_or_init(|| Mutex::new(BTreeSet::new())).lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&n) = names.get(name) {
        return n;
    }
    let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
    names.insert(leaked);
    leaked
}

/// First-order lag of a measured value y: τ·ẏ = u − y (a sensor's
/// response, Doebelin, *Measurement Systems*, first-order instruments). With
/// τ = 0 the output is the input itself and the lag has no state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lag {
    /// Time constant τ [s] (≥ 0).
    pub tau: f64,
}

/// The state of a [`Lag`].
pub const LAG_STATE: &[crate::block::StateSpec] = &[crate::block::StateSpec { name: "reading", unit: "" }];

impl Lag {
    /// Its states: one if τ > 0.
    pub fn states(&self) -> &'static [crate::block::StateSpec] {
        if self.tau > 0.0 {
            LAG_STATE
        } else {
            &[]
        }
    }
    /// The output for input `u` and states `x`.
    pub fn output(&self, u: f64, x: &[f64]) -> f64 {
        if self.tau > 0.0 {
            x.first().copied().unwrap_or(u)
        } else {
            u
        }
    }
    /// ẏ = (u − y)/τ into `out` (if there is a state).
    pub fn derivative(&self, u: f64, x: &[f64], out: &mut [f64]) {
        if let (Some(d), Some(y)) = (out.first_mut(), x.first()) {
            *d = (u - y) / self.tau;
        }
    }
    /// Partials of the output (phase `Signals`, output `row`) or of ẏ
    /// (`Derivatives`) for an input u that moves with the block's inputs as
    /// `du` lists ((input, ∂u/∂input) pairs).
    pub fn partials(&self, phase: crate::block::Phase, row: usize, du: &[(crate::block::In, f64)], d: &mut crate::block::Partials) {
        use crate::block::{In, Out, Phase};
        match phase {
            Phase::Signals if self.tau > 0.0 => d.set(Out::Signal(row), In::State(0), 1.0),
            Phase::Signals => {
                for &(input, v) in du {
                    d.add(Out::Signal(row), input, v);
                }
            }
            Phase::Derivatives if self.tau > 0.0 => {
                d.set(Out::Rate(0), In::State(0), -1.0 / self.tau);
                for &(input, v) in du {
                    d.add(Out::Rate(0), input, v / self.tau);
                }
            }
            _ => {}
        }
    }
    /// The state starts at the input (a sensor reads the initial value).
    pub fn start_at(&self, u: f64, x: &mut [f64]) {
        if let Some(y) = x.first_mut() {
            *y = u;
        }
    }
}

/// Parameters of a spool's response to its command (proportional valves).
pub const SPOOL_DYNAMICS: &[crate::params::ParamSpec] = &[
    crate::params::ParamSpec::choice("spool_order", &["first", "second"], 0, "spool response: first or second order"),
    crate::params::ParamSpec::quantity(
        "time_constant",
        units::dim::TIME,
        Some(5e-3),
        crate::params::Range::Positive,
        "ms",
        "first order: time constant",
    ),
    crate::params::ParamSpec::quantity(
        "natural_frequency",
        units::dim::FREQUENCY,
        Some(50.0),
        crate::params::Range::Positive,
        "Hz",
        "second order: natural frequency f (omega = 2 pi f)",
    ),
    crate::params::ParamSpec::quantity(
        "damping",
        units::dim::DIMENSIONLESS,
        Some(0.7),
        crate::params::Range::Closed(0.05, 10.0),
        "",
        "second order: damping ratio",
    ),
];

/// Response of a spool (or of a set value) to its command: first order
/// τ·ṡ = u − s, or second order s̈ = ω²(u − s) − 2ζω·ṡ (a mass–spring–damper
/// spool, e.g. Ogata, *Modern Control Engineering*, §5-3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spool {
    pub second_order: bool,
    pub tau: f64,
    /// Natural angular frequency ω [rad/s].
    pub omega: f64,
    pub zeta: f64,
    /// Typical size of the position (for tolerances).
    pub scale: f64,
}

const SPOOL_1: &[crate::block::StateSpec] = &[crate::block::StateSpec { name: "spool", unit: "1" }];
const SPOOL_2: &[crate::block::StateSpec] =
    &[crate::block::StateSpec { name: "spool", unit: "1" }, crate::block::StateSpec { name: "spool_rate", unit: "1/s" }];

impl Spool {
    /// From [`SPOOL_DYNAMICS`]; `scale` is the typical size of the command.
    pub fn from_params(p: &crate::params::Params, scale: f64) -> Self {
        // the frequency is stored in 1/s ("50 Hz" is 50); the angular frequency is 2π f
        let omega = 2.0 * std::f64::consts::PI * p.get("natural_frequency");
        Spool { second_order: p.choice("spool_order") == 1, tau: p.get("time_constant"), omega, zeta: p.get("damping"), scale }
    }
    pub fn states(&self) -> &'static [crate::block::StateSpec] {
        if self.second_order {
            SPOOL_2
        } else {
            SPOOL_1
        }
    }
    pub fn scales(&self, out: &mut [f64]) {
        out[0] = self.scale;
        if let Some(r) = out.get_mut(1) {
            *r = self.scale * self.omega;
        }
    }
    /// Position from the states.
    pub fn position(&self, x: &[f64]) -> f64 {
        x[0]
    }
    pub fn derivatives(&self, u: f64, x: &[f64], out: &mut [f64]) {
        if self.second_order {
            out[0] = x[1];
            out[1] = self.omega * self.omega * (u - x[0]) - 2.0 * self.zeta * self.omega * x[1];
        } else {
            out[0] = (u - x[0]) / self.tau;
        }
    }
    /// Partials of [`Spool::derivatives`] for a command u moving with the
    /// block's inputs as `du` lists.
    pub fn partials(&self, du: &[(crate::block::In, f64)], d: &mut crate::block::Partials) {
        use crate::block::{In, Out};
        let (row, gain) = if self.second_order {
            d.set(Out::Rate(0), In::State(1), 1.0);
            let w2 = self.omega * self.omega;
            d.set(Out::Rate(1), In::State(0), -w2);
            d.set(Out::Rate(1), In::State(1), -2.0 * self.zeta * self.omega);
            (1, w2)
        } else {
            d.set(Out::Rate(0), In::State(0), -1.0 / self.tau);
            (0, 1.0 / self.tau)
        };
        for &(input, v) in du {
            d.add(Out::Rate(row), input, gain * v);
        }
    }
    /// At rest at command u.
    pub fn start_at(&self, u: f64, x: &mut [f64]) {
        x[0] = u;
        if let Some(r) = x.get_mut(1) {
            *r = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_is_continuous_and_clamped() {
        assert_eq!(ramp(-1.0, 0.0, 2.0), 0.0);
        assert_eq!(ramp(1.0, 0.0, 2.0), 0.5);
        assert_eq!(ramp(3.0, 0.0, 2.0), 1.0);
        assert_eq!(ramp(0.1, 0.0, 0.0), 1.0);
    }

    #[test]
    fn switch_has_hysteresis() {
        assert!(switch_root(false, 0.5) < 0.0 && switch_root(false, 0.6) > 0.0);
        assert!(switch_root(true, 0.5) < 0.0 && switch_root(true, 0.4) > 0.0);
        assert!(switch_state(true, 0.5) && !switch_state(false, 0.5));
    }

    #[test]
    fn interpolation_holds_the_ends() {
        let (xs, ys) = ([0.0, 1.0, 2.0], [0.0, 10.0, 0.0]);
        assert_eq!(interpolate(&xs, &ys, -1.0), 0.0);
        assert_eq!(interpolate(&xs, &ys, 0.5), 5.0);
        assert_eq!(interpolate(&xs, &ys, 1.5), 5.0);
        assert_eq!(interpolate(&xs, &ys, 3.0), 0.0);
    }

    #[test]
    fn interned_names_are_shared() {
        let a = intern("a0");
        let b = intern(&String::from("a0"));
        assert!(std::ptr::eq(a, b));
    }
}
