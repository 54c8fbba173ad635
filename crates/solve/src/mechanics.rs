//! Motion of a mechanical node: sliding, sticking and end stops, decided with
//! true discrete modes (Karnopp 1985) rather than a smoothed friction law.
//!
//! A node is either sliding in a known direction — friction then opposes
//! that direction with its sliding level, and the mode ends when the velocity
//! crosses zero or a stop is hit — or held (stuck mid-stroke, or resting on a
//! stop) with v = 0 and ẍ = 0 exactly, until the applied force exceeds the
//! breakaway level in a direction the node may move. Because the mode is
//! fixed between events, the right-hand side is smooth within each interval
//! and a held piston does not creep.

use blocks::block::Stops;

/// Discrete state of a mechanical node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Moving; `dir` is +1 (extending) or −1 (retracting).
    Sliding { dir: f64 },
    /// At rest. `may_extend`/`may_retract` say in which directions it may
    /// break away (a stop forbids one).
    Held { may_extend: bool, may_retract: bool },
}

/// Forces gathered on a node at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NodeForces {
    /// Sum of forces other than dry friction [N].
    pub applied: f64,
    /// Sum of sliding friction magnitudes at the current speed [N].
    pub sliding: f64,
    /// Sum of breakaway levels [N].
    pub breakaway: f64,
}

/// Acceleration in a mode.
pub fn acceleration(mode: Mode, f: &NodeForces, mass: f64) -> f64 {
    match mode {
        Mode::Sliding { dir } => (f.applied - dir * f.sliding) / mass,
        Mode::Held { .. } => 0.0,
    }
}

/// Number of root functions per node.
pub const N_ROOTS: usize = 2;

/// Root functions of a node in its mode; a sign change is an event.
/// Sliding: [dir·v (reversal), distance to the stop ahead].
/// Held: [F − F_s if it may extend, −F − F_s if it may retract] (break away when > 0).
pub fn roots(mode: Mode, x: f64, v: f64, f: &NodeForces, stops: Option<Stops>, out: &mut [f64]) {
    match mode {
        Mode::Sliding { dir } => {
            out[0] = dir * v;
            out[1] = match stops {
                Some(s) if dir > 0.0 => s.upper - x,
                Some(s) => x - s.lower,
                None => 1.0,
            };
        }
        Mode::Held { may_extend, may_retract } => {
            out[0] = if may_extend { f.applied - f.breakaway } else { -1.0 };
            out[1] = if may_retract { -f.applied - f.breakaway } else { -1.0 };
        }
    }
}

/// The held mode for a node at rest at position x.
pub fn held_at(x: f64, stops: Option<Stops>) -> Mode {
    match stops {
        Some(s) if x <= s.lower => Mode::Held { may_extend: true, may_retract: false },
        Some(s) if x >= s.upper => Mode::Held { may_extend: false, may_retract: true },
        _ => Mode::Held { may_extend: true, may_retract: true },
    }
}

/// What to do with a node at an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    pub mode: Mode,
    /// New (x, v) to write into the inertia's states, if they change.
    pub reset: Option<(f64, f64)>,
}

/// Speed below which a bounce off a stop ends in rest [m/s].
const REST_SPEED: f64 = 1e-4;

/// Decide the next mode from the state just past an event, or `None` if the
/// node stays in its mode.
pub fn transition(mode: Mode, x: f64, v: f64, f: &NodeForces, stops: Option<Stops>) -> Option<Transition> {
    match mode {
        Mode::Sliding { dir } => {
            if let Some(s) = stops {
                let hit = (dir > 0.0 && x >= s.upper) || (dir < 0.0 && x <= s.lower);
                if hit {
                    let at = if dir > 0.0 { s.upper } else { s.lower };
                    let rebound = -s.restitution * v;
                    if rebound.abs() < REST_SPEED {
                        let mode = held_at(at, stops);
                        // The node may leave the stop at once if the force already pulls it away.
                        let mode = breakaway(mode, f).unwrap_or(mode);
                        return Some(Transition { mode, reset: Some((at, 0.0)) });
                    }
                    return Some(Transition { mode: Mode::Sliding { dir: -dir }, reset: Some((at, rebound)) });
                }
            }
            if dir * v <= 0.0 {
                // velocity reversal: stick if the friction can hold the applied force (Karnopp)
                let held = held_at(x, stops);
                let mode = breakaway(held, f).unwrap_or(held);
                return Some(Transition { mode, reset: Some((x, 0.0)) });
            }
            None
        }
        Mode::Held { .. } => breakaway(mode, f).map(|mode| Transition { mode, reset: None }),
    }
}

/// A held node breaks away when the applied force exceeds the breakaway level
/// in a permitted direction.
pub fn breakaway(mode: Mode, f: &NodeForces) -> Option<Mode> {
    match mode {
        Mode::Held { may_extend, may_retract } => {
            if may_extend && f.applied > f.breakaway {
                Some(Mode::Sliding { dir: 1.0 })
            } else if may_retract && -f.applied > f.breakaway {
                Some(Mode::Sliding { dir: -1.0 })
            } else {
                None
            }
        }
        Mode::Sliding { .. } => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STOPS: Option<Stops> = Some(Stops { lower: 0.0, upper: 0.45, restitution: 0.0 });

    #[test]
    fn stuck_node_holds_below_breakaway_with_zero_acceleration() {
        let f = NodeForces { applied: 13.0, sliding: 14.0, breakaway: 14.0 };
        let held = held_at(0.2, STOPS);
        assert_eq!(breakaway(held, &f), None);
        assert_eq!(acceleration(held, &f, 1.0), 0.0);
        let f = NodeForces { applied: 14.5, ..f };
        assert_eq!(breakaway(held, &f), Some(Mode::Sliding { dir: 1.0 }));
    }

    #[test]
    fn stop_forbids_motion_into_it() {
        let at_zero = held_at(0.0, STOPS);
        let push_in = NodeForces { applied: -100.0, sliding: 10.0, breakaway: 10.0 };
        assert_eq!(breakaway(at_zero, &push_in), None);
        let pull_out = NodeForces { applied: 100.0, ..push_in };
        assert_eq!(breakaway(at_zero, &pull_out), Some(Mode::Sliding { dir: 1.0 }));
    }

    #[test]
    fn inelastic_impact_rests_on_the_stop() {
        let f = NodeForces { applied: 50.0, sliding: 10.0, breakaway: 10.0 };
        let t = transition(Mode::Sliding { dir: 1.0 }, 0.4500000001, 0.8, &f, STOPS).unwrap();
        assert_eq!(t.reset, Some((0.45, 0.0)));
        assert_eq!(t.mode, Mode::Held { may_extend: false, may_retract: true });
    }

    #[test]
    fn elastic_impact_rebounds() {
        let stops = Some(Stops { lower: 0.0, upper: 0.45, restitution: 0.5 });
        let f = NodeForces::default();
        let t = transition(Mode::Sliding { dir: -1.0 }, -1e-12, -0.8, &f, stops).unwrap();
        assert_eq!(t.reset, Some((0.0, 0.4)));
        assert_eq!(t.mode, Mode::Sliding { dir: 1.0 });
    }

    #[test]
    fn reversal_sticks_or_slides_back_after_karnopp() {
        let weak = NodeForces { applied: -5.0, sliding: 10.0, breakaway: 10.0 };
        let t = transition(Mode::Sliding { dir: 1.0 }, 0.2, -1e-12, &weak, STOPS).unwrap();
        assert!(matches!(t.mode, Mode::Held { .. }));
        let strong = NodeForces { applied: -15.0, ..weak };
        let t = transition(Mode::Sliding { dir: 1.0 }, 0.2, -1e-12, &strong, STOPS).unwrap();
        assert_eq!(t.mode, Mode::Sliding { dir: -1.0 });
        assert_eq!(t.reset, Some((0.2, 0.0)));
    }

    #[test]
    fn sliding_decelerates_against_friction() {
        let f = NodeForces { applied: 0.0, sliding: 20.0, breakaway: 20.0 };
        assert_eq!(acceleration(Mode::Sliding { dir: 1.0 }, &f, 2.0), -10.0);
        assert_eq!(acceleration(Mode::Sliding { dir: -1.0 }, &f, 2.0), 10.0);
    }
}
