//! Lines, restrictions and non-return valves (ISO 1219-1): the flexible
//! line, the throttle (two arcs narrowing the passage), the laminar
//! capillary, the check valve (a ball on a seat: free flow lifts the ball),
//! the one-way flow control (throttle and check in one chain-dotted
//! enclosure), the quick-exhaust, shuttle (OR) and two-pressure (AND)
//! valves.
//!
//! Two-port symbols are drawn with port `a` at the bottom and `b` on top;
//! the layout turns them over when `b` is nearer the supply.

use super::Member;
use crate::format;
use crate::shape::{Anchor, Dir, Fill, PinKind, Prim, Shape, Stroke, G};

/// Pins `a` at the bottom and `b` on top of a vertical line at x.
fn two_pins(s: &mut Shape, x: f64, named: bool) {
    let h = s.h;
    s.pin(0, "a", x, h, Dir::Down, PinKind::Working);
    s.pin(0, "b", x, 0.0, Dir::Up, PinKind::Working);
    if named {
        s.port_name(x, h, Dir::Down, "a");
        s.port_name(x, 0.0, Dir::Up, "b");
    }
}

/// Hose or pipe: a flexible line (an arc).
pub fn tube(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 6.0 * G);
    s.line(20.0, 0.0, 20.0, 10.0);
    s.prims.push(Prim::Arc { from: (20.0, 10.0), to: (20.0, 50.0), r: 24.0, sweep: true, stroke: Stroke::Solid });
    s.line(20.0, 50.0, 20.0, 60.0);
    two_pins(&mut s, 20.0, false);
    s.label = vec![format!("{} × Ø{}", m.show("length"), m.show("diameter")), format!("{} segments", m.get("segments"))];
    if m.word("inertia") == "yes" {
        s.label.push("with gas inertia".into());
    }
    s
}

/// Fixed ISO 6358 restriction: a throttle.
pub fn conductance(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 4.0 * G);
    s.line(20.0, 0.0, 20.0, 40.0);
    s.throttle(20.0, 12.0, 28.0);
    two_pins(&mut s, 20.0, false);
    s.label = vec![m.iso6358()];
    s
}

/// Laminar restriction: a long narrow channel.
pub fn capillary(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 4.0 * G);
    s.line(20.0, 0.0, 20.0, 40.0);
    s.line(16.0, 8.0, 16.0, 32.0);
    s.line(24.0, 8.0, 24.0, 32.0);
    two_pins(&mut s, 20.0, false);
    s.label = vec![format!("{} (laminar)", m.named("k", "k"))];
    s
}

/// Check valve: free flow from `a` (bottom) to `b` (top).
pub fn check_valve(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 4.0 * G);
    let spring = m.get("cracking_pressure") > 0.0;
    s.line(20.0, 40.0, 20.0, 28.0);
    s.check(20.0, 28.0, 18.0, spring);
    s.line(20.0, 0.0, 20.0, if spring { 5.5 } else { 13.5 });
    two_pins(&mut s, 20.0, true);
    s.label = vec![m.iso6358()];
    if spring {
        s.label.push(m.named("cracking", "cracking_pressure"));
    }
    s
}

/// One-way flow control: an adjustable throttle with a check valve in
/// parallel, free flow from `a` (bottom) to `b` (top), throttled from `b` to `a`.
pub fn speed_control(m: &Member) -> Shape {
    let mut s = Shape::new(6.0 * G, 6.0 * G);
    s.line(20.0, 0.0, 20.0, 60.0);
    s.throttle(20.0, 22.0, 38.0);
    s.adjustable(20.0, 30.0, 11.0);
    // the bypass with the check valve
    s.poly(vec![(20.0, 12.0), (42.0, 12.0), (42.0, 22.0)]);
    s.check(42.0, 37.0, 27.0, m.get("cracking_pressure") > 0.0);
    s.poly(vec![(42.0, 37.0), (42.0, 48.0), (20.0, 48.0)]);
    s.circle(20.0, 12.0, 2.0, Fill::Black);
    s.circle(20.0, 48.0, 2.0, Fill::Black);
    s.prims.push(Prim::Rect { x: 5.0, y: 5.0, w: 50.0, h: 50.0, rx: 0.0, stroke: Stroke::Chain, fill: Fill::None });
    two_pins(&mut s, 20.0, true);
    s.label = vec![format!("throttle {}", m.iso6358()), format!("check C {}", m.show("check_C")), "free a→b, throttled b→a".to_string()];
    s
}

/// Quick-exhaust valve: fills A from P, vents A straight to E.
pub fn quick_exhaust(m: &Member) -> Shape {
    let mut s = Shape::new(6.0 * G, 6.0 * G);
    s.rect(10.0, 20.0, 40.0, 20.0);
    s.line(20.0, 0.0, 20.0, 20.0);
    s.line(20.0, 60.0, 20.0, 40.0);
    s.line(40.0, 40.0, 40.0, 60.0);
    // the disc, lifted off the P seat towards E
    s.line(14.0, 36.0, 26.0, 36.0);
    s.circle(30.0, 30.0, 5.0, Fill::White);
    s.line(34.0, 36.0, 46.0, 36.0);
    s.pin(0, "P", 20.0, 60.0, Dir::Down, PinKind::Working);
    s.pin(0, "A", 20.0, 0.0, Dir::Up, PinKind::Working);
    s.pin(0, "E", 40.0, 60.0, Dir::Down, PinKind::Working);
    s.port_name(20.0, 60.0, Dir::Down, "P/1");
    s.port_name(20.0, 0.0, Dir::Up, "A/2");
    s.port_name(40.0, 60.0, Dir::Down, "R/3");
    s.label = vec!["quick exhaust".into(), m.iso6358(), format!("exhaust C {}", m.show("C_exhaust"))];
    s
}

/// Shuttle valve (OR) and two-pressure valve (AND): inlets at the ends of
/// a horizontal body, the outlet in the middle.
pub fn shuttle(m: &Member) -> Shape {
    let and = m.ty.name == "two_pressure_valve";
    let mut s = Shape::new(6.0 * G, 4.0 * G);
    s.rect(14.0, 12.0, 32.0, 16.0);
    s.poly(vec![(10.0, 40.0), (10.0, 20.0), (14.0, 20.0)]);
    s.poly(vec![(50.0, 40.0), (50.0, 20.0), (46.0, 20.0)]);
    s.line(30.0, 0.0, 30.0, 12.0);
    if and {
        // a double piston: whichever inlet is lower feeds the outlet
        s.rect(20.0, 14.0, 6.0, 12.0);
        s.rect(34.0, 14.0, 6.0, 12.0);
        s.line(26.0, 20.0, 34.0, 20.0);
    } else {
        s.circle(21.0, 20.0, 5.0, Fill::White);
    }
    s.text(30.0, 38.0, if and { "&" } else { "≥1" }, 8.0, Anchor::Middle);
    s.pin(0, "P1", 10.0, 40.0, Dir::Down, PinKind::Working);
    s.pin(0, "P2", 50.0, 40.0, Dir::Down, PinKind::Working);
    s.pin(0, "A", 30.0, 0.0, Dir::Up, PinKind::Working);
    s.port_name(10.0, 40.0, Dir::Down, "P1/1");
    s.port_name(50.0, 40.0, Dir::Down, "P2/1");
    s.port_name(30.0, 0.0, Dir::Up, "A/2");
    s.label = vec![if and { "two-pressure (AND)".into() } else { "shuttle (OR)".to_string() }, m.iso6358()];
    if m.given("shift_pressure") {
        s.label.push(format!("shift {}", format::quantity(m.get("shift_pressure"), "bar")));
    }
    s
}
