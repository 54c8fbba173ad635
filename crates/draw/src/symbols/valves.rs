//! Directional control valves (ISO 1219-1): one square per switching
//! position, flow paths as arrows, blocked ports as T, the actuators at the
//! ends — the one next to a square produces that position. Lines attach to
//! the square of the normal position (the spring side of a 2-position
//! valve, the centre of a 3-position valve). Ports are named as on the
//! valve body, letters with the ISO 5599-3 numbers: P/1 supply, A/4 and
//! B/2 working ports, R/5 and S/3 their exhausts; 14 and 12 are the
//! actuators that connect 1 to 4 and 1 to 2.
//!
//! The netlist's ports map as: `P` → P/1, `A` → A/4, `B` → B/2, `EA` → R/5,
//! `EB` → S/3 (5/2, 5/3, proportional); `P` → P/1, `A` → A/2, `E` → R/3
//! (3/2); `a` → P/1, `b` → A/2 (2/2).

use super::Member;
use crate::format;
use crate::shape::{Dir, PinKind, Prim, Shape, Stroke, G};

/// A port on the valve's squares: its x inside a square and its side.
#[derive(Clone, Copy)]
struct Port {
    name: &'static str,
    label: &'static str,
    x: f64,
    top: bool,
}

/// A flow path from port to port (indices into the port list) or a blocked port.
enum Path {
    Flow(usize, usize),
    Blocked(usize),
}

enum Actuator {
    Solenoid { port: &'static str, proportional: bool },
    Pilot { port: &'static str },
    Spring,
    Detent,
}

struct Valve {
    square: f64,
    ports: Vec<Port>,
    positions: Vec<Vec<Path>>,
    /// The square the lines attach to.
    normal: usize,
    left: Vec<Actuator>,
    right: Vec<Actuator>,
    proportional: bool,
}

const SIDE: f64 = 2.0 * G;

const FIVE_PORTS: [Port; 5] = [
    Port { name: "P", label: "P/1", x: 30.0, top: false },
    Port { name: "A", label: "A/4", x: 10.0, top: true },
    Port { name: "B", label: "B/2", x: 50.0, top: true },
    Port { name: "EA", label: "R/5", x: 10.0, top: false },
    Port { name: "EB", label: "S/3", x: 50.0, top: false },
];
const P: usize = 0;
const A: usize = 1;
const B: usize = 2;
const EA: usize = 3;
const EB: usize = 4;

/// Position 14 of a 5-port valve: P→A, B→EB, EA blocked.
fn five_14() -> Vec<Path> {
    vec![Path::Flow(P, A), Path::Flow(B, EB), Path::Blocked(EA)]
}
/// Position 12 of a 5-port valve: P→B, A→EA, EB blocked.
fn five_12() -> Vec<Path> {
    vec![Path::Flow(P, B), Path::Flow(A, EA), Path::Blocked(EB)]
}

/// A 3/2 or 2/2 valve, single solenoid with spring return, on 40 px
/// squares: `open` is the position with P→A, `shut` the other; a normally
/// open valve rests in `open`.
fn two_position(m: &Member, ports: Vec<Port>, open: Vec<Path>, shut: Vec<Path>) -> Valve {
    let positions = if m.word("normally_open") == "yes" { vec![shut, open] } else { vec![open, shut] };
    Valve {
        square: 4.0 * G,
        ports,
        positions,
        normal: 1,
        left: vec![Actuator::Solenoid { port: "command", proportional: false }],
        right: vec![Actuator::Spring],
        proportional: false,
    }
}

fn valve_of(m: &Member) -> Valve {
    match m.ty.name {
        "valve_5_2" => Valve {
            square: 6.0 * G,
            ports: FIVE_PORTS.to_vec(),
            positions: vec![five_14(), five_12()],
            normal: 1,
            left: vec![Actuator::Solenoid { port: "command", proportional: false }],
            right: vec![Actuator::Spring],
            proportional: false,
        },
        "valve_3_2" => {
            let ports = vec![
                Port { name: "P", label: "P/1", x: 10.0, top: false },
                Port { name: "A", label: "A/2", x: 10.0, top: true },
                Port { name: "E", label: "R/3", x: 30.0, top: false },
            ];
            two_position(m, ports, vec![Path::Flow(0, 1), Path::Blocked(2)], vec![Path::Flow(1, 2), Path::Blocked(0)])
        }
        "valve_2_2" => {
            let ports = vec![Port { name: "a", label: "P/1", x: 20.0, top: false }, Port { name: "b", label: "A/2", x: 20.0, top: true }];
            two_position(m, ports, vec![Path::Flow(0, 1)], vec![Path::Blocked(0), Path::Blocked(1)])
        }
        "valve_5_3" => {
            let centre = match m.word("centre") {
                "exhaust" => vec![Path::Flow(A, EA), Path::Flow(B, EB), Path::Blocked(P)],
                "pressure" => vec![Path::Flow(P, A), Path::Flow(P, B), Path::Blocked(EA), Path::Blocked(EB)],
                _ => (0..5).map(Path::Blocked).collect(),
            };
            let pilot = m.word("actuation") == "pilot";
            let ret = || if m.word("return") == "detent" { Actuator::Detent } else { Actuator::Spring };
            let act = |sol: &'static str, pil: &'static str| {
                if pilot {
                    Actuator::Pilot { port: pil }
                } else {
                    Actuator::Solenoid { port: sol, proportional: false }
                }
            };
            Valve {
                square: 6.0 * G,
                ports: FIVE_PORTS.to_vec(),
                positions: vec![five_14(), centre, five_12()],
                normal: 1,
                left: vec![act("sol_14", "pilot_14"), ret()],
                right: vec![act("sol_12", "pilot_12"), ret()],
                proportional: false,
            }
        }
        // proportional_valve: u > 0 is position 14 (P→A), u < 0 position 12
        _ => Valve {
            square: 6.0 * G,
            ports: FIVE_PORTS.to_vec(),
            positions: vec![five_14(), (0..5).map(Path::Blocked).collect(), five_12()],
            normal: 1,
            left: vec![Actuator::Solenoid { port: "u", proportional: true }, Actuator::Spring],
            right: vec![Actuator::Spring],
            proportional: true,
        },
    }
}

/// The symbol of a directional valve (2/2, 3/2, 5/2, 5/3, proportional 5/3).
pub fn directional(m: &Member) -> Shape {
    let v = valve_of(m);
    let b = v.square;
    let n = v.positions.len() as f64;
    let left = if v.left.is_empty() { 0.0 } else { SIDE };
    let right = if v.right.is_empty() { 0.0 } else { SIDE };
    let mut s = Shape::new(left + n * b + right, b);
    let box_x = |i: usize| left + i as f64 * b;
    for (i, paths) in v.positions.iter().enumerate() {
        let x0 = box_x(i);
        s.rect(x0, 0.0, b, b);
        let at = |p: usize| {
            let port = v.ports[p];
            (x0 + port.x, if port.top { 0.0 } else { b })
        };
        for path in paths {
            match *path {
                Path::Flow(from, to) => {
                    let (f, t) = (at(from), at(to));
                    // stop the arrow just inside the square's edge
                    let inset = |p: (f64, f64), top: bool| (p.0, if top { p.1 + 1.0 } else { p.1 - 1.0 });
                    s.arrow(inset(f, v.ports[from].top), inset(t, v.ports[to].top));
                }
                Path::Blocked(p) => {
                    let (x, y) = at(p);
                    s.blocked(x, y, if v.ports[p].top { 1.0 } else { -1.0 });
                }
            }
        }
    }
    if v.proportional {
        // continuous positions: lines along the squares, above and below
        let (x0, x1) = (box_x(0), box_x(v.positions.len()));
        s.styled_line(vec![(x0, -3.0), (x1, -3.0)], Stroke::Thin);
        s.styled_line(vec![(x0, b + 3.0), (x1, b + 3.0)], Stroke::Thin);
    }
    // the ports, on the square of the normal position
    for port in &v.ports {
        if !m.has_port(port.name) {
            continue;
        }
        let x = box_x(v.normal) + port.x;
        let (y, dir) = if port.top { (0.0, Dir::Up) } else { (b, Dir::Down) };
        s.pin(0, port.name, x, y, dir, PinKind::Working);
        s.port_name(x, y, dir, port.label);
    }
    actuators(&mut s, m, &v.left, 0.0, left, true);
    actuators(&mut s, m, &v.right, left + n * b, right, false);
    s.label = label(m);
    s
}

/// Draw the actuators of one end, stacked from the top.
fn actuators(s: &mut Shape, m: &Member, list: &[Actuator], x0: f64, width: f64, left_side: bool) {
    let b = s.h;
    let centres: Vec<f64> = match list.len() {
        0 => return,
        1 => vec![(b / 2.0 / G).round() * G],
        _ => vec![(b * 0.3 / G).round() * G, (b * 0.7 / G).round() * G],
    };
    // x of the square's edge this end touches, and the outward direction
    let (edge, out) = if left_side { (x0 + width, -1.0) } else { (x0, 1.0) };
    let outer = if left_side { x0 } else { x0 + width };
    let dir = if left_side { Dir::Left } else { Dir::Right };
    for (act, &cy) in list.iter().zip(&centres) {
        let slot = if list.len() == 1 { (b * 0.45).min(22.0) } else { (b * 0.36).min(18.0) };
        match act {
            Actuator::Solenoid { port, proportional } => {
                let w = 12.0;
                let x = if left_side { edge - w } else { edge };
                s.solenoid(x, cy - slot / 2.0, w, slot, *proportional);
                if m.has_port(port) {
                    let inner = if left_side { x } else { x + w };
                    s.line(outer, cy, inner, cy);
                    s.pin(0, port, outer, cy, dir, PinKind::SignalIn);
                    s.port_name(outer, cy, dir, port_label(port));
                }
            }
            Actuator::Pilot { port } => {
                // an open triangle pointing into the square, fed by a dashed pilot line
                let base = edge + out * 9.0;
                s.polygon(vec![(edge, cy), (base, cy - 5.0), (base, cy + 5.0)], crate::shape::Fill::White);
                if m.has_port(port) {
                    s.styled_line(vec![(outer, cy), (base, cy)], Stroke::Dashed);
                    s.pin(0, port, outer, cy, dir, PinKind::Pilot);
                    s.port_name(outer, cy, dir, port_label(port));
                }
            }
            Actuator::Spring => {
                s.spring((edge, cy), (edge + out * (width - 2.0), cy), 3, 4.0);
            }
            Actuator::Detent => {
                // a latch bar with a notch
                let x1 = edge + out * (width - 4.0);
                s.prims.push(Prim::Polyline {
                    pts: vec![(edge, cy), (x1, cy), (x1, cy - 5.0), (x1 - out * 3.0, cy - 2.0), (x1 - out * 6.0, cy - 5.0)],
                    stroke: Stroke::Thin,
                });
            }
        }
    }
}

fn port_label(port: &str) -> &str {
    match port {
        "sol_14" | "pilot_14" => "14",
        "sol_12" | "pilot_12" => "12",
        "command" => "Y",
        other => other,
    }
}

fn label(m: &Member) -> Vec<String> {
    let mut l = Vec::new();
    let kind = match m.ty.name {
        "valve_5_2" => "5/2, solenoid, spring return".to_string(),
        "valve_3_2" => format!("3/2 {}, solenoid", if m.word("normally_open") == "yes" { "normally open" } else { "normally closed" }),
        "valve_2_2" => format!("2/2 {}, solenoid", if m.word("normally_open") == "yes" { "normally open" } else { "normally closed" }),
        "valve_5_3" => format!(
            "5/3 {} centre, {}, {}",
            m.word("centre"),
            m.word("actuation"),
            if m.word("return") == "detent" { "detent" } else { "spring-centred" }
        ),
        _ => "proportional 5/3, zero lap".to_string(),
    };
    l.push(kind);
    l.push(m.iso6358());
    if m.ty.params.iter().any(|p| p.name == "C_exhaust") && m.get("C_exhaust") > 0.0 {
        l.push(m.named("exhaust C", "C_exhaust"));
    }
    if m.ty.params.iter().any(|p| p.name == "C_leak") && m.get("C_leak") > 0.0 {
        l.push(m.named("leak C", "C_leak"));
    }
    if m.ty.params.iter().any(|p| p.name == "switching_time") && m.get("switching_time") > 0.0 {
        l.push(m.named("switching", "switching_time"));
    }
    if m.ty.name == "proportional_valve" {
        if m.word("spool_order") == "second" {
            l.push(format!("spool {}, ζ {}", m.show("natural_frequency"), format::sig(m.get("damping"), 3)));
        } else {
            l.push(m.named("spool τ", "time_constant"));
        }
    }
    l
}
