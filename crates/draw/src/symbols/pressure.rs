//! Pressure control valves (ISO 1219-1): one square with its flow path, a
//! spring on one side (adjustable: an arrow through it) and the pilot line
//! (dashed) that senses the controlled pressure on the other. The
//! regulator is normally open (its arrow on the port axis), the relief
//! valve normally closed (its arrow off the axis). A proportional pressure
//! valve has a proportional solenoid in place of the adjustable spring.

use super::Member;
use crate::format;
use crate::shape::{Dir, Fill, PinKind, Shape, Stroke};

/// The square, spring or proportional solenoid, and the pilot from the port at `(20, pilot_y)`.
fn body(s: &mut Shape, pilot_y: f64, proportional: bool) {
    s.rect(10.0, 10.0, 40.0, 40.0);
    s.styled_line(vec![(20.0, pilot_y), (4.0, pilot_y), (4.0, 30.0), (10.0, 30.0)], Stroke::Dashed);
    s.circle(20.0, pilot_y, 1.8, Fill::Black);
    if proportional {
        s.solenoid(50.0, 22.0, 8.0, 16.0, true);
    } else {
        s.spring((50.0, 30.0), (60.0, 30.0), 3, 4.0);
        s.adjustable(55.0, 30.0, 7.0);
    }
}

/// Pressure-reducing valve (relieving or not), and the proportional pressure valve.
pub fn regulator(m: &Member) -> Shape {
    let proportional = m.ty.name == "proportional_pressure_valve";
    let mut s = Shape::new(if proportional { 70.0 } else { 60.0 }, 60.0);
    s.line(20.0, 0.0, 20.0, 10.0);
    s.line(20.0, 50.0, 20.0, 60.0);
    body(&mut s, 5.0, proportional);
    s.arrow((20.0, 49.0), (20.0, 11.0));
    s.pin(0, "P", 20.0, 60.0, Dir::Down, PinKind::Working);
    s.pin(0, "A", 20.0, 0.0, Dir::Up, PinKind::Working);
    s.port_name(20.0, 60.0, Dir::Down, "P/1");
    s.port_name(20.0, 0.0, Dir::Up, "A/2");
    if m.has_port("E") {
        // the relief path opens only above the set pressure: closed at rest
        s.line(40.0, 50.0, 40.0, 60.0);
        s.blocked(40.0, 50.0, -1.0);
        s.pin(0, "E", 40.0, 60.0, Dir::Down, PinKind::Working);
        s.port_name(40.0, 60.0, Dir::Down, "R/3");
    }
    if proportional {
        s.line(58.0, 30.0, 70.0, 30.0);
        s.pin(0, "p_set", 70.0, 30.0, Dir::Right, PinKind::SignalIn);
        s.label = vec!["proportional pressure valve".into(), m.iso6358()];
        if m.word("spool_order") == "second" {
            s.label.push(format!("response {}, ζ {}", m.show("natural_frequency"), format::sig(m.get("damping"), 3)));
        } else {
            s.label.push(m.named("response τ", "time_constant"));
        }
    } else {
        s.label = vec![format!("set {}", format::pressure(m.get("p_set"))), m.iso6358(), m.named("droop", "droop")];
    }
    if !m.has_port("E") {
        s.label.push("non-relieving".into());
    }
    s
}

/// Pressure-relief valve: opens P to E above the cracking pressure.
pub fn relief(m: &Member) -> Shape {
    let mut s = Shape::new(60.0, 60.0);
    s.line(20.0, 0.0, 20.0, 10.0);
    s.line(20.0, 50.0, 20.0, 60.0);
    body(&mut s, 5.0, false);
    s.arrow((30.0, 11.0), (30.0, 49.0));
    s.pin(0, "P", 20.0, 0.0, Dir::Up, PinKind::Working);
    s.pin(0, "E", 20.0, 60.0, Dir::Down, PinKind::Working);
    s.port_name(20.0, 0.0, Dir::Up, "P/1");
    s.port_name(20.0, 60.0, Dir::Down, "R/3");
    s.label = vec![format!("cracking Δp {}", m.show("p_crack")), m.iso6358()];
    s
}
