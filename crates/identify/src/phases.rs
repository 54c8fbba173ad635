//! Phases of an actuator cycle, from the simulated valve command and piston
//! position: where in the cycle a residual occurs.
//!
//! For each command switch (the command crossing 0.5) at time t_c, with
//! x_c = x(t_c) and target end 0 or the stroke S:
//! - `switching`: from t_c until the piston has left x_c by more than
//!   [`MOVE_THRESHOLD`] (valve and chamber transients before motion);
//! - `breakaway`: motion started, less than 10 % of the travel covered;
//! - `steady`: 10 % to 90 % of the travel;
//! - `end_of_stroke`: beyond 90 % of the travel, up to 0.1 s after the
//!   piston arrived within [`MOVE_THRESHOLD`] of the end (cushioning,
//!   impact and the pressure settling that follows);
//! - `rest`: everything else (before the first command, dwells at the ends).
//!
//! Units: s, m. Assumes one cylinder and a two-level command (0/1).
//!
//! A circuit without a cylinder (a vessel's blowdown or filling) has its
//! own phases, from the simulated pressure of its first vessel
//! ([`classify_vessel`]): `charge` and `discharge` while the pressure
//! moves faster than 1 % of its fastest rate, `hold` otherwise.

use serde::Serialize;

/// Displacement that counts as motion [m].
pub const MOVE_THRESHOLD: f64 = 5e-4;
/// Time after arrival still counted as end of stroke [s].
pub const SETTLE_TIME: f64 = 0.1;

/// A phase of the cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    Switching,
    Breakaway,
    Steady,
    EndOfStroke,
    Rest,
    /// A vessel filling.
    Charge,
    /// A vessel emptying.
    Discharge,
    /// A vessel whose pressure stands (nearly) still.
    Hold,
}

impl Phase {
    pub const ALL: [Phase; 8] =
        [Phase::Switching, Phase::Breakaway, Phase::Steady, Phase::EndOfStroke, Phase::Rest, Phase::Charge, Phase::Discharge, Phase::Hold];
    pub fn name(self) -> &'static str {
        match self {
            Phase::Switching => "switching",
            Phase::Breakaway => "breakaway",
            Phase::Steady => "steady",
            Phase::EndOfStroke => "end_of_stroke",
            Phase::Rest => "rest",
            Phase::Charge => "charge",
            Phase::Discharge => "discharge",
            Phase::Hold => "hold",
        }
    }
}

/// Phase of every sample; `command`, `x` are sampled at `times` (increasing).
pub fn classify(times: &[f64], command: &[f64], x: &[f64], stroke: f64) -> Vec<Phase> {
    let n = times.len().min(command.len()).min(x.len());
    let mut out = vec![Phase::Rest; times.len()];
    // switch indices
    let mut switches = Vec::new();
    for i in 1..n {
        if (command[i - 1] >= 0.5) != (command[i] >= 0.5) {
            switches.push(i);
        }
    }
    if n > 0 && command[0] >= 0.5 {
        switches.insert(0, 0); // commanded from the start
    }
    for (w, &s) in switches.iter().enumerate() {
        let end = switches.get(w + 1).copied().unwrap_or(n);
        let extend = command[s] >= 0.5;
        let xc = x[s];
        let target = if extend { stroke } else { 0.0 };
        let travel = target - xc;
        let mut moving_since: Option<usize> = None;
        let mut arrived_at: Option<f64> = None;
        for i in s..end {
            if moving_since.is_none() && (x[i] - xc).abs() > MOVE_THRESHOLD {
                moving_since = Some(i);
            }
            if moving_since.is_some() && arrived_at.is_none() && (x[i] - target).abs() <= MOVE_THRESHOLD {
                arrived_at = Some(times[i]);
            }
            out[i] = match (moving_since, arrived_at) {
                (None, _) if travel.abs() > MOVE_THRESHOLD => Phase::Switching,
                (None, _) => {
                    // already at the target: the valve switch only moves pressures
                    if times[i] - times[s] <= SETTLE_TIME {
                        Phase::Switching
                    } else {
                        Phase::Rest
                    }
                }
                (Some(_), Some(ta)) => {
                    if times[i] - ta <= SETTLE_TIME {
                        Phase::EndOfStroke
                    } else {
                        Phase::Rest
                    }
                }
                (Some(_), None) => {
                    let f = if travel.abs() > 0.0 { (x[i] - xc) / travel } else { 1.0 };
                    if f < 0.1 {
                        Phase::Breakaway
                    } else if f < 0.9 {
                        Phase::Steady
                    } else {
                        Phase::EndOfStroke
                    }
                }
            };
        }
    }
    out
}

/// Phases of a vessel test from its pressure `p` at `times` (see the module header).
pub fn classify_vessel(times: &[f64], p: &[f64]) -> Vec<Phase> {
    let n = times.len().min(p.len());
    let rate: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n.saturating_sub(1)));
            let dt = times[b] - times[a];
            if dt > 0.0 {
                (p[b] - p[a]) / dt
            } else {
                0.0
            }
        })
        .collect();
    let fastest = rate.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
    let mut out: Vec<Phase> = rate
        .iter()
        .map(|&r| {
            if fastest > 0.0 && r.abs() > 0.01 * fastest {
                if r > 0.0 {
                    Phase::Charge
                } else {
                    Phase::Discharge
                }
            } else {
                Phase::Hold
            }
        })
        .collect();
    out.resize(times.len(), Phase::Hold);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blowdown_discharges_then_holds() {
        let times: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        let p: Vec<f64> = times.iter().map(|&t| if t < 1.0 { 1e5 } else { 1e5 + 6e5 * (-(t - 1.0) / 0.5).exp() }).collect();
        let p: Vec<f64> = p.iter().zip(&times).map(|(v, &t)| if t < 1.0 { 7e5 } else { *v }).collect();
        let ph = classify_vessel(&times, &p);
        assert_eq!(ph[50], Phase::Hold);
        assert_eq!(ph[120], Phase::Discharge);
        assert_eq!(ph[900], Phase::Hold);
        let rising: Vec<f64> = p.iter().map(|v| 8e5 - v).collect();
        assert_eq!(classify_vessel(&times, &rising)[120], Phase::Charge);
    }

    #[test]
    fn a_synthetic_cycle_is_cut_where_expected() {
        // rest 0.1 s, extend command at 0.1 s, motion starts at 0.15 s,
        // constant speed 0.5 m/s over 0.45 m (arrives 1.05 s), dwell, retract at 1.4 s
        let dt = 1e-3;
        let times: Vec<f64> = (0..2000).map(|i| i as f64 * dt).collect();
        let command: Vec<f64> = times.iter().map(|&t| if (0.1..1.4).contains(&t) { 1.0 } else { 0.0 }).collect();
        let x: Vec<f64> = times
            .iter()
            .map(|&t| {
                if t < 0.15 {
                    0.0
                } else if t < 1.05 {
                    0.5 * (t - 0.15)
                } else if t < 1.45 {
                    0.45
                } else {
                    (0.45 - 1.0 * (t - 1.45)).max(0.0)
                }
            })
            .collect();
        let ph = classify(&times, &command, &x, 0.45);
        let at = |t: f64| ph[(t / dt).round() as usize];
        assert_eq!(at(0.05), Phase::Rest);
        assert_eq!(at(0.12), Phase::Switching);
        assert_eq!(at(0.16), Phase::Breakaway); // 5 mm of 450 mm
        assert_eq!(at(0.5), Phase::Steady);
        assert_eq!(at(1.0), Phase::EndOfStroke); // 92 % of the travel
        assert_eq!(at(1.1), Phase::EndOfStroke); // 50 ms after arrival
        assert_eq!(at(1.3), Phase::Rest);
        assert_eq!(at(1.42), Phase::Switching); // retract commanded, not moving yet
        assert_eq!(at(1.47), Phase::Breakaway); // 20 mm back: 4 % of the travel
        assert_eq!(at(1.6), Phase::Steady);
        assert_eq!(at(1.87), Phase::EndOfStroke); // 30 mm from home: 93 % of the travel
        assert_eq!(at(1.95), Phase::EndOfStroke); // arrived at 1.90 s, settling
    }
}
