//! Signal blocks — controllers, sequencers, timers, logic, PID — as
//! function boxes (IEC 60617-12 style: the function's sign in the box),
//! their id and settings written inside, every port a pin on the right
//! edge with its name (inputs receive an arrowhead). They stand in a column
//! beside the pneumatic circuit, joined to it by dashed signal lines.

use super::Member;
use crate::format;
use crate::shape::{Anchor, Dir, Fill, PinKind, Prim, Shape, G};
use crate::svg::shorten;
use crate::text::width;
use blocks::block::{Domain, PortKind};

const LINE: f64 = 12.0;
const BODY_SIZE: f64 = 9.0;
const TITLE_SIZE: f64 = 10.0;
/// Lines of settings shown at most (a long sequencer is cut with "…").
const MAX_LINES: usize = 16;
const MAX_CHARS: usize = 44;

/// The box of a signal block with its settings.
pub fn block(m: &Member) -> Shape {
    let (title, lines) = match m.ty.name {
        "schedule" => ("schedule", schedule(m)),
        "cycler" => {
            let mut l = vec![format!("extend ⇄ retract at {}", m.show("stroke"))];
            if m.get("cycles") > 0.0 {
                l.push(format!("{} cycles", m.get("cycles")));
            }
            for (name, what) in [("dwell_extended", "dwell out"), ("dwell_retracted", "dwell in"), ("start", "start")] {
                if m.get(name) > 0.0 {
                    l.push(m.named(what, name));
                }
            }
            ("cycler", l)
        }
        "delay" => ("delay", vec![m.named("Δt", "delay")]),
        "sequencer" => ("GRAFCET", sequencer(m)),
        "timer" => {
            let mode = match m.word("mode") {
                "off_delay" => "TOF",
                "pulse" => "TP",
                _ => "TON",
            };
            ("timer", vec![format!("{mode} {}", m.show("delay"))])
        }
        "logic_gate" => return gate(m),
        "pid" => (
            "PID",
            vec![
                format!("kp {}, ki {}", format::sig(m.get("kp"), 3), m.show("ki")),
                format!("kd {}, filter {}", m.show("kd"), m.show("derivative_filter")),
                format!("u ∈ [{}, {}]", format::sig(m.get("u_min"), 3), format::sig(m.get("u_max"), 3)),
            ],
        ),
        other => (other, Vec::new()),
    };
    boxed(m, title, &lines)
}

fn list(values: &[f64], unit: &str) -> String {
    let shown: Vec<String> = values.iter().map(|v| format::sig(*v, 3)).collect();
    if unit.is_empty() {
        shown.join(", ")
    } else {
        format!("{} {unit}", shown.join(", "))
    }
}

fn schedule(m: &Member) -> Vec<String> {
    let times = m.params.list("times");
    let values = m.params.list("values");
    let mut l = vec![format!("before: {}", format::sig(m.get("initial"), 3))];
    if !times.is_empty() {
        l.push(format!("at {}", list(times, "s")));
        l.push(format!("set {}", list(values, "")));
    }
    l
}

fn sequencer(m: &Member) -> Vec<String> {
    let mut l: Vec<String> = m.params.words("transitions").iter().map(|t| t.replace("->", "→")).collect();
    for a in m.params.words("actions") {
        l.push(format!("▸ {a}"));
    }
    if m.get("cycles") > 0.0 {
        l.push(format!("{} cycles", m.get("cycles")));
    }
    l
}

/// A box titled `title` with `lines` of settings and a pin per port:
/// signals on the right edge, pneumatic and mechanical ports at the bottom.
pub fn boxed(m: &Member, title: &str, lines: &[String]) -> Shape {
    let mut lines: Vec<String> = lines.iter().map(|l| shorten(l, MAX_CHARS)).collect();
    if lines.len() > MAX_LINES {
        lines.truncate(MAX_LINES - 1);
        lines.push("…".into());
    }
    let signals: Vec<&blocks::block::PortSpec> = m.ports.iter().filter(|p| p.kind.domain() == Domain::Signal).collect();
    let power: Vec<&blocks::block::PortSpec> = m.ports.iter().filter(|p| p.kind.domain() != Domain::Signal).collect();
    let pin_names: Vec<String> = signals.iter().map(|p| shorten(p.name, 12)).collect();
    let text_w = std::iter::once(width(m.id, TITLE_SIZE))
        .chain(std::iter::once(width(title, BODY_SIZE)))
        .chain(lines.iter().map(|l| width(l, BODY_SIZE)))
        .fold(0.0, f64::max);
    let pin_w = pin_names.iter().map(|n| width(n, 8.0)).fold(0.0, f64::max);
    let w = ((text_w + pin_w + 22.0) / G).ceil() * G;
    let w = w.max(8.0 * G).max((power.len() as f64 + 1.0) * 2.0 * G);
    let text_h = 2.0 * LINE + lines.len() as f64 * LINE + 8.0;
    let pins_h = (signals.len() as f64 + 1.0) * 2.0 * G;
    let h = (text_h.max(pins_h) / G).ceil() * G;
    let mut s = Shape::new(w, h);
    s.prims.push(Prim::Rect { x: 0.0, y: 0.0, w, h, rx: 0.0, stroke: crate::shape::Stroke::Solid, fill: Fill::White });
    s.bold_text(5.0, 13.0, &shorten(m.id, 40), TITLE_SIZE, Anchor::Start);
    s.prims.push(Prim::Text {
        x: 5.0,
        y: 13.0 + LINE,
        text: title.to_string(),
        size: BODY_SIZE,
        anchor: Anchor::Start,
        bold: false,
        italic: true,
    });
    for (i, l) in lines.iter().enumerate() {
        s.text(5.0, 13.0 + LINE * (i as f64 + 2.0), l, BODY_SIZE, Anchor::Start);
    }
    for (i, (p, name)) in signals.iter().zip(&pin_names).enumerate() {
        let y = 2.0 * G * (i as f64 + 1.0);
        let kind = if p.kind == PortKind::SignalIn { PinKind::SignalIn } else { PinKind::SignalOut };
        s.pin(0, p.name, w, y, Dir::Right, kind);
        s.text(w - 4.0, y + 3.0, name, 8.0, Anchor::End);
    }
    for (i, p) in power.iter().enumerate() {
        let x = 2.0 * G * (i as f64 + 1.0);
        let kind = if p.kind.domain() == Domain::Pneumatic { PinKind::Working } else { PinKind::Mechanical };
        s.pin(0, p.name, x, h, Dir::Down, kind);
        s.port_name(x, h, Dir::Down, p.name);
    }
    s
}

/// A logic gate: the IEC sign in a box, an inversion circle at the output
/// of NAND, NOR and NOT.
fn gate(m: &Member) -> Shape {
    let op = m.word("operation");
    let sign = match op {
        "or" | "nor" => "≥1",
        "xor" => "=1",
        "not" => "1",
        _ => "&",
    };
    let mut s = boxed(m, &format!("logic {}", op.to_uppercase()), &[]);
    let (w, h) = (s.w, s.h);
    s.text(w * 0.4, h - 8.0, sign, 14.0, Anchor::Middle);
    if matches!(op, "nand" | "nor" | "not") {
        if let Some(out) = s.pins.iter().find(|p| p.port == "out").map(|p| p.y) {
            s.circle(w - 14.0, out, 3.0, Fill::White);
        }
    }
    s
}
