//! PID controller with output limits, anti-windup by back-calculation and a
//! filtered derivative on the measurement.
//!
//! # Ports
//! - `setpoint`, `measurement` — signal inputs, in one unit (e.g. m).
//! - `u` [1] — signal output: the command, within [u_min, u_max].
//!
//! # Parameters (defaults in brackets)
//! - `kp` [1, 1], `ki` [1/s, 0], `kd` [s, 0]: gains in output units per SI
//!   unit of the error (a position loop: kp = 20 means 20 per metre).
//! - `derivative_filter` [s, 2 ms, > 0]: time constant T_f of the
//!   derivative's first-order filter.
//! - `u_min` [-1], `u_max` [1]: output limits.
//! - `tracking_time` [s, auto]: back-calculation time constant T_t; by
//!   default √(T_i·T_d) with a derivative, T_i without (T_i = kp/ki, T_d = kd/kp).
//! - `u_idle` [0]: output at rest, before t = 0 (the controller released).
//!
//! # Equations (Åström & Hägglund, *Advanced PID Control*, 2006, §3.4–3.5)
//! e = r − y; filtered measurement T_f·ẏ_f = y − y_f; derivative on the
//! measurement D = −kd·(y − y_f)/T_f; v = kp·e + I + D; u = clamp(v, u_min, u_max);
//! İ = ki·e + (u − v)/T_t (back-calculation: while the output saturates the
//! integral is driven back so that v stays within about ki·e·T_t of the limit).
//!
//! # Assumptions
//! Continuous-time controller (no sampling); derivative on the measurement
//! only, so a setpoint step gives no derivative kick.

use crate::block::*;
use crate::params::{ParamSpec, Params, Range};
use units::dim;

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::quantity("kp", dim::DIMENSIONLESS, Some(1.0), Range::Any, "", "proportional gain (output per unit error)"),
    ParamSpec::quantity("ki", dim::FREQUENCY, Some(0.0), Range::NonNegative, "1/s", "integral gain (per unit error and second)"),
    ParamSpec::quantity("kd", dim::TIME, Some(0.0), Range::NonNegative, "s", "derivative gain (per unit error rate)"),
    ParamSpec::quantity("derivative_filter", dim::TIME, Some(2e-3), Range::Positive, "ms", "derivative filter time constant"),
    ParamSpec::quantity("u_min", dim::DIMENSIONLESS, Some(-1.0), Range::Any, "", "lower output limit"),
    ParamSpec::quantity("u_max", dim::DIMENSIONLESS, Some(1.0), Range::Any, "", "upper output limit"),
    ParamSpec::quantity("tracking_time", dim::TIME, Some(0.0), Range::NonNegative, "s", "anti-windup time constant (0 = auto)"),
    ParamSpec::quantity("u_idle", dim::DIMENSIONLESS, Some(0.0), Range::Any, "", "output at rest before t = 0"),
];
pub const PORTS: &[PortSpec] = &[
    PortSpec::signal("setpoint", PortKind::SignalIn, "", "reference r"),
    PortSpec::signal("measurement", PortKind::SignalIn, "", "measured y (unit of r)"),
    PortSpec::signal("u", PortKind::SignalOut, "1", "command"),
];
pub const OUTPUTS: &[OutputSpec] = &[OutputSpec { name: "error", unit: "" }, OutputSpec { name: "integral", unit: "1" }];
const STATES_ID: &[StateSpec] = &[StateSpec { name: "integral", unit: "1" }, StateSpec { name: "y_filtered", unit: "" }];

#[derive(Debug, Clone, PartialEq)]
pub struct Pid {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    pub tf: f64,
    pub u_min: f64,
    pub u_max: f64,
    pub tt: f64,
    pub u_idle: f64,
}

impl Pid {
    pub fn from_params(p: &Params) -> Result<Self, crate::BlockError> {
        let (kp, ki, kd) = (p.get("kp"), p.get("ki"), p.get("kd"));
        let (u_min, u_max) = (p.get("u_min"), p.get("u_max"));
        if u_min >= u_max {
            return Err(crate::BlockError::invalid("u_max", "must be above u_min"));
        }
        let tt = if p.get("tracking_time") > 0.0 {
            p.get("tracking_time")
        } else if ki > 0.0 {
            let ti = if kp != 0.0 { kp.abs() / ki } else { 1.0 / ki };
            if kd > 0.0 && kp != 0.0 {
                (ti * kd / kp.abs()).sqrt()
            } else {
                ti
            }
        } else {
            1.0
        };
        Ok(Pid { kp, ki, kd, tf: p.get("derivative_filter"), u_min, u_max, tt, u_idle: p.get("u_idle") })
    }
    /// Unsaturated output v and saturated output u from inputs and states (I, y_f).
    pub fn output(&self, r: f64, y: f64, states: &[f64]) -> (f64, f64) {
        let e = r - y;
        let (i, yf) = (states[0], states[1]);
        let d = if self.kd > 0.0 { -self.kd * (y - yf) / self.tf } else { 0.0 };
        let v = self.kp * e + i + d;
        (v, v.clamp(self.u_min, self.u_max))
    }
}

impl Block for Pid {
    fn type_name(&self) -> &'static str {
        "pid"
    }
    fn ports(&self) -> &[PortSpec] {
        PORTS
    }
    fn gas_role(&self) -> GasRole {
        GasRole::None
    }
    fn states(&self) -> &[StateSpec] {
        STATES_ID
    }
    fn state_scales(&self, _init: &[f64], out: &mut [f64]) {
        out[0] = (self.u_max - self.u_min).abs().max(1e-9);
        out[1] = 1.0;
    }
    fn initial_states_from_inputs(&self, ctx: &Ctx, states: &mut [f64]) {
        states[0] = 0.0;
        states[1] = ctx.signals[1];
    }
    fn feedthrough(&self) -> bool {
        true
    }
    fn signal_outputs(&self, ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.output(ctx.signals[0], ctx.signals[1], ctx.states).1;
    }
    fn rest_signal_outputs(&self, _ctx: &Ctx, out: &mut [f64]) {
        out[0] = self.u_idle.clamp(self.u_min, self.u_max);
    }
    fn derivatives(&self, ctx: &Ctx, _b: &Balances, out: &mut [f64]) {
        let (r, y) = (ctx.signals[0], ctx.signals[1]);
        let (v, u) = self.output(r, y, ctx.states);
        out[0] = if self.ki > 0.0 { self.ki * (r - y) + (u - v) / self.tt } else { 0.0 };
        out[1] = (y - ctx.states[1]) / self.tf;
    }
    fn partials(&self, phase: Phase, ctx: &Ctx, _b: &Balances, d: &mut Partials) -> bool {
        // v = kp e + i + d_term with e = r − y, d_term = −kd (y − y_f)/t_f; u = clamp(v)
        let (r, y) = (ctx.signals[0], ctx.signals[1]);
        let (v, _) = self.output(r, y, ctx.states);
        let kd = if self.kd > 0.0 { self.kd / self.tf } else { 0.0 };
        let dv = [(In::Signal(0), self.kp), (In::Signal(1), -self.kp - kd), (In::State(0), 1.0), (In::State(1), kd)];
        let passes = if v > self.u_min && v < self.u_max { 1.0 } else { 0.0 };
        match phase {
            Phase::Signals => {
                for (i, x) in dv {
                    d.add(Out::Signal(0), i, passes * x);
                }
            }
            Phase::Derivatives => {
                if self.ki > 0.0 {
                    d.add(Out::Rate(0), In::Signal(0), self.ki);
                    d.add(Out::Rate(0), In::Signal(1), -self.ki);
                    for (i, x) in dv {
                        d.add(Out::Rate(0), i, (passes - 1.0) * x / self.tt);
                    }
                }
                d.set(Out::Rate(1), In::Signal(1), 1.0 / self.tf);
                d.set(Out::Rate(1), In::State(1), -1.0 / self.tf);
            }
            _ => {}
        }
        true
    }
    fn outputs(&self) -> &[OutputSpec] {
        OUTPUTS
    }
    fn record(&self, ctx: &Ctx, _b: &Balances, _d: &[f64], out: &mut [Option<f64>]) {
        out[0] = Some(ctx.signals[0] - ctx.signals[1]);
        out[1] = Some(ctx.states[0]);
    }
}

/// Registry entry of `pid`.
pub const TYPE: crate::registry::BlockType = crate::registry::BlockType {
    name: "pid",
    family: crate::registry::Family::Control,
    doc: "PID controller: output limits, back-calculation anti-windup",
    params: PARAMS,
    ports: PORTS,
    outputs: OUTPUTS,
    build: |p| crate::registry::boxed(Pid::from_params(p)),
};

#[cfg(test)]
mod tests {
    use super::*;

    fn pid(kp: f64, ki: f64, kd: f64) -> Pid {
        Pid { kp, ki, kd, tf: 1e-3, u_min: -1.0, u_max: 1.0, tt: if ki > 0.0 { kp / ki } else { 1.0 }, u_idle: 0.0 }
    }

    /// Integrate the controller on the plant ẏ = (K u − y)/τ by RK4; returns (t, y, u) samples.
    fn closed_loop(c: &Pid, r: f64, k: f64, tau: f64, t_end: f64) -> Vec<(f64, f64, f64, f64)> {
        let gas = gas::IdealGas::air();
        let dt = 1e-5;
        // state: plant y, integral, filtered y
        let f = |x: &[f64; 3]| -> [f64; 3] {
            let sig = [r, x[0]];
            let ctx = Ctx { t: 0.0, gas: &gas, states: &x[1..], pneumatic: &[], mechanical: &[], signals: &sig };
            let mut u = [0.0];
            c.signal_outputs(&ctx, &mut u);
            let mut d = [0.0; 2];
            c.derivatives(&ctx, &Balances { pneumatic: &[], mechanical: &[] }, &mut d);
            [(k * u[0] - x[0]) / tau, d[0], d[1]]
        };
        let mut x = [0.0; 3];
        let mut t = 0.0;
        let mut out = Vec::new();
        while t < t_end {
            let k1 = f(&x);
            let k2 = f(&std::array::from_fn(|i| x[i] + 0.5 * dt * k1[i]));
            let k3 = f(&std::array::from_fn(|i| x[i] + 0.5 * dt * k2[i]));
            let k4 = f(&std::array::from_fn(|i| x[i] + dt * k3[i]));
            for i in 0..3 {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += dt;
            let (_, u) = c.output(r, x[0], &x[1..]);
            out.push((t, x[0], u, x[1]));
        }
        out
    }

    #[test]
    fn proportional_loop_settles_at_the_closed_form_offset() {
        // P control of a first-order plant: y∞ = K kp r/(1 + K kp), reached with time constant τ/(1 + K kp)
        let c = pid(4.0, 0.0, 0.0);
        let r = closed_loop(&c, 0.2, 1.0, 0.05, 0.2);
        let y_inf = 4.0 * 0.2 / 5.0;
        let y_end = r.last().unwrap().1;
        assert!((y_end - y_inf).abs() < 1e-6, "{y_end} vs {y_inf}");
        let t_c = 0.05 / 5.0;
        let at = r.iter().find(|s| s.0 >= t_c).unwrap();
        assert!((at.1 - y_inf * (1.0 - (-1.0f64).exp())).abs() < 1e-3, "{}", at.1);
    }

    #[test]
    fn integral_removes_the_offset_and_back_calculation_prevents_windup() {
        // a setpoint the plant can reach only with u near its limit: PI with and without anti-windup
        let mut c = pid(2.0, 20.0, 0.0);
        let r = closed_loop(&c, 0.95, 1.0, 0.05, 1.5);
        assert!((r.last().unwrap().1 - 0.95).abs() < 1e-4, "no steady offset with integral action");
        // unreachable setpoint: the output saturates, and the integral settles where
        // İ = ki e∞ + (u_max − v)/T_t = 0: I∞ = u_max − kp e∞ + ki e∞ T_t, e∞ = r − K u_max
        let r_hi = 2.0;
        let run = closed_loop(&c, r_hi, 1.0, 0.05, 3.0);
        let e = r_hi - 1.0;
        let i_inf = 1.0 - c.kp * e + c.ki * e * c.tt;
        let (_, y_end, u_end, i_end) = *run.last().unwrap();
        assert!((y_end - 1.0).abs() < 1e-6 && u_end == 1.0);
        assert!((i_end - i_inf).abs() < 1e-6, "{i_end} vs {i_inf}");
        // without back-calculation (T_t → ∞) the integral winds up by ki·e per second
        c.tt = 1e12;
        let wound = closed_loop(&c, r_hi, 1.0, 0.05, 3.0);
        let i_wound = wound.last().unwrap().3;
        assert!(i_wound > 50.0, "{i_wound}");
    }

    #[test]
    fn derivative_acts_on_the_filtered_measurement_only() {
        let c = pid(1.0, 0.0, 0.01);
        // measurement 0.1 above its filtered value: D = −kd (y − y_f)/T_f = −1
        let (v, u) = c.output(0.5, 0.3, &[0.0, 0.2]);
        assert!((v - (0.2 - 1.0)).abs() < 1e-12 && (u - v).abs() < 1e-12);
        // a setpoint step gives no derivative kick
        let (v2, _) = c.output(1.5, 0.3, &[0.0, 0.3]);
        assert!((v2 - 1.2).abs() < 1e-12);
    }
}
