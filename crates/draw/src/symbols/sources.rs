//! Sources and exhausts: the compressed-air supply (a circle with an open,
//! pneumatic triangle pointing to its port), a prescribed mass flow, and
//! the exhaust to atmosphere (an open triangle pointing away from the port;
//! in a circuit drawn at every port that vents, not as one block).

use super::Member;
use crate::format;
use crate::shape::{Dir, Fill, PinKind, Shape, G};

/// Supply: pin on top, the circle below it.
pub fn pressure_source(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 4.0 * G);
    let (cx, cy, r) = (20.0, 25.0, 11.0);
    s.line(cx, 0.0, cx, cy - r);
    s.circle(cx, cy, r, Fill::White);
    s.polygon(vec![(cx, cy - 7.0), (cx - 6.0, cy + 4.0), (cx + 6.0, cy + 4.0)], Fill::White);
    s.pin(0, "port", cx, 0.0, Dir::Up, PinKind::Working);
    s.label = vec![format!("p {}", format::pressure(m.get("p")))];
    if (m.get("T") - 293.15).abs() > 0.005 {
        s.label.push(m.named("T", "T"));
    }
    s
}

/// Atmosphere on its own (the block catalogue): an exhaust under its pin.
pub fn atmosphere(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 3.0 * G);
    s.exhaust(20.0, 0.0, Dir::Down, 8.0);
    s.pin(0, "port", 20.0, 0.0, Dir::Up, PinKind::Working);
    s.label = vec![format!("exhaust, p {}", format::pressure(m.get("p")))];
    s
}

/// Prescribed mass flow: a circle with a flow arrow.
pub fn mass_flow_source(m: &Member) -> Shape {
    let mut s = Shape::new(4.0 * G, 4.0 * G);
    let (cx, cy, r) = (20.0, 25.0, 11.0);
    s.line(cx, 0.0, cx, cy - r);
    s.circle(cx, cy, r, Fill::White);
    s.arrow((cx - 6.0, cy + 6.0), (cx + 6.0, cy - 6.0));
    s.pin(0, "port", cx, 0.0, Dir::Up, PinKind::Working);
    s.label = vec![m.named("ṁ", "mdot"), m.named("T", "T")];
    s
}
