//! Sensors: measuring instruments are circles (ISO 1219-1) with the
//! quantity they read; their signal leaves on top. Sensors on a cylinder's
//! rod are drawn on the cylinder ([`super::actuators::cylinder`]); the
//! symbols here are for a rod sensor or switch standing alone.

use super::Member;
use crate::shape::{Anchor, Dir, Fill, PinKind, Shape};

/// Pressure or temperature of a node: an instrument on a branch line.
pub fn gauge(m: &Member) -> Shape {
    let mut s = Shape::new(40.0, 40.0);
    let (letter, out) = if m.ty.name == "pressure_sensor" { ("p", "p") } else { ("T", "T") };
    s.line(20.0, 40.0, 20.0, 30.0);
    s.circle(20.0, 20.0, 10.0, Fill::White);
    s.text(20.0, 24.0, letter, 11.0, Anchor::Middle);
    s.line(20.0, 10.0, 20.0, 0.0);
    s.pin(0, "port", 20.0, 40.0, Dir::Down, PinKind::Working);
    s.pin(0, out, 20.0, 0.0, Dir::Up, PinKind::SignalOut);
    s.label = vec![m.named("τ", "time_constant")];
    if m.ty.params.iter().any(|p| p.name == "reading") && m.word("reading") == "gauge" {
        s.label.push("gauge reading".into());
    }
    s
}

/// In-line flow meter with mass-flow and free-air-flow outputs.
pub fn flow_meter(m: &Member) -> Shape {
    let mut s = Shape::new(40.0, 60.0);
    s.line(20.0, 0.0, 20.0, 20.0);
    s.line(20.0, 40.0, 20.0, 60.0);
    s.circle(20.0, 30.0, 10.0, Fill::White);
    s.arrow((20.0, 37.0), (20.0, 23.0));
    s.line(30.0, 30.0, 34.0, 30.0);
    s.poly(vec![(34.0, 20.0), (34.0, 40.0)]);
    s.line(34.0, 20.0, 40.0, 20.0);
    s.line(34.0, 40.0, 40.0, 40.0);
    s.pin(0, "a", 20.0, 60.0, Dir::Down, PinKind::Working);
    s.pin(0, "b", 20.0, 0.0, Dir::Up, PinKind::Working);
    s.port_name(20.0, 60.0, Dir::Down, "a");
    s.port_name(20.0, 0.0, Dir::Up, "b");
    s.pin(0, "mdot", 40.0, 20.0, Dir::Right, PinKind::SignalOut);
    s.pin(0, "Q", 40.0, 40.0, Dir::Right, PinKind::SignalOut);
    s.port_name(40.0, 20.0, Dir::Right, "ṁ");
    s.port_name(40.0, 40.0, Dir::Right, "Q");
    s.label = vec![m.iso6358(), m.named("τ", "time_constant")];
    s
}

/// A rod sensor or limit switch not mounted on a cylinder.
pub fn on_rod(m: &Member) -> Shape {
    let mut s = Shape::new(40.0, 30.0);
    s.rect(5.0, 5.0, 30.0, 20.0);
    let (glyph, out, label) = match m.ty.name {
        "position_sensor" => ("x", "x", m.named("τ", "time_constant")),
        "velocity_sensor" => ("v", "v", m.named("τ", "time_constant")),
        _ => ("LS", "on", format!("at {} ({})", m.show("position"), m.word("actuated"))),
    };
    s.text(20.0, 19.0, glyph, 10.0, Anchor::Middle);
    s.line(20.0, 25.0, 20.0, 30.0);
    s.line(20.0, 5.0, 20.0, 0.0);
    s.pin(0, "rod", 20.0, 30.0, Dir::Down, PinKind::Mechanical);
    s.pin(0, out, 20.0, 0.0, Dir::Up, PinKind::SignalOut);
    s.label = vec![label];
    s
}
