//! Actuators and capacities: the cylinder (ISO 1219-1: barrel, piston,
//! rod; ports at the ends), drawn from a piston and every block on its
//! mechanical node — chambers (head side left, rod side right), springs
//! inside the chamber they push from, a load at the rod end, cushioning at
//! the end it brakes, and the rod's switches and sensors above the barrel
//! at their positions — and the air receiver (a capsule) for a chamber
//! without a piston. Blocks of a cylinder that stand alone (a piston with
//! no chamber, say) are drawn as labelled boxes.

use super::{control, Ctx, Member};
use crate::format;
use crate::shape::{Anchor, Dir, Fill, PinKind, Prim, Shape, Stroke, G};

/// Height of the barrel [px].
const BARREL: f64 = 4.0 * G;
/// Height of the band above the barrel that carries switches and signal pins.
const BAND: f64 = 4.0 * G;
/// How far the rod sticks out of the retracted cylinder [px].
const ROD_OUT: f64 = 4.0 * G;

/// The last segment of an id: what a reader sees inside its subsystem frame.
pub fn local(id: &str) -> &str {
    id.rsplit('.').next().unwrap_or(id)
}

/// A pin on top of the cylinder: preferred x, member, port, the x of the
/// thing it comes from, how far down that is, and its name.
struct TopPin {
    x: f64,
    member: usize,
    port: &'static str,
    kind: PinKind,
    anchor: (f64, f64),
    name: String,
}

/// The cylinder made of `ctx.members` (one piston and the blocks on its node).
pub fn cylinder(ctx: &Ctx) -> Shape {
    let ms = ctx.members;
    let of = |ty: &str| -> Vec<usize> { (0..ms.len()).filter(|&i| ms[i].ty.name == ty).collect() };
    let piston = of("piston").first().copied().unwrap_or(0);
    let p = &ms[piston];
    let chambers = of("chamber");
    let head: Vec<usize> = chambers.iter().copied().filter(|&i| ms[i].word("orientation") == "extend").collect();
    let rod: Vec<usize> = chambers.iter().copied().filter(|&i| ms[i].word("orientation") == "retract").collect();
    let stroke = p.get("stroke");
    let loads = of("load");
    let springs = of("spring");
    let cushions = of("cushion");

    let length = ((120.0 + stroke * 1e3 * 0.25).clamp(140.0, 260.0) / (2.0 * G)).round() * 2.0 * G;
    let load_w = if loads.is_empty() { 0.0 } else { 3.0 * G };
    let w = ((length + ROD_OUT + load_w + 2.0) / G).ceil() * G;
    let band = BAND;
    let mut s = Shape::new(w, band + BARREL);
    let (top, cy, bottom) = (band, band + BARREL / 2.0, band + BARREL);
    let travel = length - 30.0;
    let frac = |x: f64| if stroke > 0.0 { (x / stroke).clamp(0.0, 1.0) } else { 0.0 };
    let piston_at = |x: f64| 10.0 + frac(x) * travel;

    // barrel, piston, rod
    s.rect(0.0, top, length, BARREL);
    let xp = piston_at(p.get("x0"));
    let rod_end = length + ROD_OUT;
    s.styled_rect(xp + 6.0, cy - 3.0, rod_end - xp - 6.0, 6.0, Stroke::Solid, Fill::White);
    s.styled_rect(xp, top, 6.0, BARREL, Stroke::Solid, Fill::Black);
    if !loads.is_empty() {
        let x = rod_end;
        s.rect(x, cy - 12.0, 24.0, 24.0);
        s.text(x + 12.0, cy + 4.0, "m", 11.0, Anchor::Middle);
    }
    for &i in &springs {
        // a spring lives in the chamber it pushes from
        let (a, b) = if ms[i].word("direction") == "retract" { (xp + 6.0, length) } else { (0.0, xp) };
        s.spring((a, cy), (b, cy), 5, BARREL / 2.0 - 5.0);
    }
    for &i in &cushions {
        let at_rod_end = ms[i].word("end") == "extend";
        let x = if at_rod_end { length - 14.0 } else { 4.0 };
        s.rect(x, cy - 8.0, 10.0, 16.0);
        s.adjustable(x + 5.0, cy, 14.0);
    }

    // ports at the bottom: through a cushion when one sits in the chamber's line
    let mut bottom_pins: Vec<(f64, usize, &'static str, String)> = Vec::new();
    let line_of = |chamber: usize| -> (usize, &'static str) {
        for &c in &cushions {
            if ctx.used(c, "line") && ms[c].word("end") == if ms[chamber].word("orientation") == "retract" { "extend" } else { "retract" } {
                return (c, "line");
            }
        }
        (chamber, "port")
    };
    for (k, &i) in head.iter().enumerate() {
        let (member, port) = line_of(i);
        bottom_pins.push((2.0 * G * (k as f64 + 1.0), member, port, local(ms[i].id).to_string()));
    }
    for (k, &i) in rod.iter().enumerate() {
        let (member, port) = line_of(i);
        bottom_pins.push((length - 2.0 * G * (k as f64 + 1.0), member, port, local(ms[i].id).to_string()));
    }
    // a cushion whose chamber is not part of this cylinder still shows its line
    for &c in &cushions {
        if ctx.used(c, "line") && !bottom_pins.iter().any(|b| b.1 == c) {
            bottom_pins.push((length / 2.0, c, "line", local(ms[c].id).to_string()));
        }
    }
    for (x, member, port, name) in &bottom_pins {
        s.pin(*member, port, *x, bottom, Dir::Down, PinKind::Working);
        s.port_name(*x, bottom, Dir::Down, name);
    }

    // switches, sensors and signals above the barrel
    let mut tops: Vec<TopPin> = Vec::new();
    for (i, m) in ms.iter().enumerate() {
        match m.ty.name {
            "limit_switch" => {
                let x = piston_at(m.get("position")) + 3.0;
                s.line(x, top, x, top - 6.0);
                s.polygon(vec![(x - 4.0, top - 6.0), (x + 4.0, top - 6.0), (x, top - 12.0)], Fill::White);
                if ctx.used(i, "on") {
                    tops.push(TopPin {
                        x,
                        member: i,
                        port: "on",
                        kind: PinKind::SignalOut,
                        anchor: (x, top - 12.0),
                        name: local(m.id).into(),
                    });
                } else {
                    s.text(x, top - 14.0, local(m.id), 8.0, Anchor::Middle);
                }
            }
            "position_sensor" | "velocity_sensor" => {
                let out = if m.ty.name == "position_sensor" { "x" } else { "v" };
                // mid-barrel, clear of the switches at the stroke ends
                let x = length / 2.0 - 30.0 * tops.iter().filter(|t| t.port == "x" || t.port == "v").count() as f64;
                s.rect(x - 9.0, top - 14.0, 18.0, 10.0);
                s.text(x, top - 6.5, out, 8.0, Anchor::Middle);
                s.styled_line(vec![(x, top - 4.0), (x, top)], Stroke::Thin);
                tops.push(TopPin { x, member: i, port: out, kind: PinKind::SignalOut, anchor: (x, top - 14.0), name: local(m.id).into() });
            }
            _ => {
                for port in m.ports.iter().filter(|p| p.kind.domain() == blocks::block::Domain::Signal) {
                    if !ctx.used(i, port.name) {
                        continue;
                    }
                    let kind = if port.kind == blocks::block::PortKind::SignalIn { PinKind::SignalIn } else { PinKind::SignalOut };
                    let x = match (m.ty.name, port.name) {
                        ("chamber", _) if m.word("orientation") == "retract" => length - 40.0,
                        ("chamber", _) => 40.0,
                        ("piston", _) => length - 10.0,
                        _ => length / 2.0,
                    };
                    tops.push(TopPin {
                        x,
                        member: i,
                        port: port.name,
                        kind,
                        anchor: (x, top),
                        name: format!("{}.{}", local(m.id), port.name),
                    });
                }
            }
        }
    }
    place_top_pins(&mut s, tops);
    s.label = cylinder_label(ms, piston, &head, &rod, &springs, &loads, &cushions);
    s
}

/// Put the top pins on distinct grid positions near where they want to be
/// and join each to its anchor.
fn place_top_pins(s: &mut Shape, mut tops: Vec<TopPin>) {
    tops.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.member.cmp(&b.member)));
    let mut last = f64::NEG_INFINITY;
    let mut last_text_end = f64::NEG_INFINITY;
    let mut high = false;
    for t in tops {
        let x = ((t.x / G).round() * G).max(last + 2.0 * G).max(G).min(s.w - G);
        last = x;
        let (ax, ay) = t.anchor;
        let stroke = Stroke::Dashed;
        if (ax - x).abs() < 0.5 {
            s.styled_line(vec![(x, 0.0), (x, ay)], stroke);
        } else {
            s.styled_line(vec![(x, 0.0), (x, 8.0), (ax, 8.0), (ax, ay)], stroke);
        }
        s.pin(t.member, t.port, x, 0.0, Dir::Up, t.kind);
        // names that would run into the previous one go on a second line
        high = x + 3.0 < last_text_end && !high;
        last_text_end = x + 3.0 + crate::text::width(&t.name, 7.5) + 2.0;
        let y = if high { 7.0 } else { 16.0 };
        s.prims.push(Prim::Text { x: x + 3.0, y, text: t.name, size: 7.5, anchor: Anchor::Start, bold: false, italic: false });
    }
}

fn bore_of(m: &Member) -> f64 {
    if m.get("bore") > 0.0 {
        m.get("bore")
    } else {
        (4.0 * m.get("area") / std::f64::consts::PI).sqrt()
    }
}

fn cylinder_label(
    ms: &[Member],
    piston: usize,
    head: &[usize],
    rod: &[usize],
    springs: &[usize],
    loads: &[usize],
    cushions: &[usize],
) -> Vec<String> {
    let p = &ms[piston];
    let bore = head.iter().chain(rod).map(|&i| bore_of(&ms[i])).find(|b| *b > 0.0).unwrap_or(0.0);
    let rod_d = rod.iter().map(|&i| ms[i].get("rod_diameter")).find(|d| *d > 0.0).unwrap_or(p.get("rod_diameter"));
    let mm = |x: f64| format::sig(x * 1e3, 3);
    let size = if rod_d > 0.0 {
        format!("Ø{}/{} × {} mm", mm(bore), mm(rod_d), mm(p.get("stroke")))
    } else {
        format!("Ø{} × {} mm", mm(bore), mm(p.get("stroke")))
    };
    let kind = match (head.is_empty(), rod.is_empty(), springs.is_empty()) {
        (false, false, true) => "double-acting",
        (false, false, false) => "double-acting, spring",
        (false, true, _) | (true, false, _) if !springs.is_empty() => "single-acting, spring return",
        _ => "single-acting",
    };
    let mut l = vec![format!("{kind} {size}"), format!("moving mass {}", p.show("mass"))];
    // "spring: 0.2 N/mm" — without repeating an id that says what the block is
    let named = |i: usize, what: String| {
        let id = local(ms[i].id);
        match what.strip_prefix(id).filter(|rest| rest.starts_with(' ')) {
            Some(rest) => format!("{id}:{rest}"),
            None => format!("{id}: {what}"),
        }
    };
    for &i in loads {
        let m = &ms[i];
        let mut t = format!("load {}", m.show("mass"));
        if m.get("angle") != 0.0 {
            t.push_str(&format!(" at {} (lifting)", m.show("angle")));
        }
        if !m.params.list("forces").is_empty() {
            t.push_str(", force table");
        }
        l.push(named(i, t));
    }
    for &i in springs {
        l.push(named(i, format!("spring {}, preload {}", ms[i].show("stiffness"), ms[i].show("preload"))));
    }
    for &i in cushions {
        l.push(named(i, format!("cushion {}, needle C {}", ms[i].show("cushion_length"), ms[i].show("C_needle"))));
    }
    for (i, m) in ms.iter().enumerate() {
        match m.ty.name {
            "friction" => l.push(named(i, format!("Eq. 37, k0 {}, k2 {}", m.show("k0"), m.show("k2")))),
            "position_sensor" | "velocity_sensor" if m.get("time_constant") > 0.0 => l.push(named(
                i,
                format!("{} sensor, τ {}", if m.ty.name == "position_sensor" { "position" } else { "velocity" }, m.show("time_constant")),
            )),
            _ => {}
        }
    }
    if p.get("external_force") != 0.0 {
        l.push(p.named("force", "external_force"));
    }
    l
}

/// An air receiver (a chamber without a piston): a capsule.
pub fn tank(ctx: &Ctx) -> Shape {
    let m = &ctx.members[0];
    let mut s = Shape::new(6.0 * G, 4.0 * G);
    s.prims.push(Prim::Rect { x: 0.0, y: 10.0, w: 60.0, h: 24.0, rx: 12.0, stroke: Stroke::Solid, fill: Fill::White });
    s.line(30.0, 34.0, 30.0, 40.0);
    s.pin(0, "port", 30.0, 40.0, Dir::Down, PinKind::Working);
    for (k, out) in ["p", "T"].iter().enumerate() {
        if ctx.used(0, out) {
            let x = 20.0 + 20.0 * k as f64;
            s.styled_line(vec![(x, 0.0), (x, 10.0)], Stroke::Dashed);
            s.pin(0, out, x, 0.0, Dir::Up, PinKind::SignalOut);
            s.port_name(x, 0.0, Dir::Right, out);
        }
    }
    let v = m.get("dead_volume");
    s.label = vec![if v >= 1e-3 { format!("V {}", format::quantity(v, "L")) } else { m.named("V", "dead_volume") }];
    if m.given("p0") {
        s.label.push(format!("p0 {}", format::pressure(m.get("p0"))));
    }
    if m.get("tau_thermal").is_infinite() {
        s.label.push("adiabatic".into());
    } else {
        s.label.push(m.named("τ_T", "tau_thermal"));
    }
    s
}

/// A block of the mechanics drawn on its own (not on a cylinder).
pub fn mechanical(ctx: &Ctx) -> Shape {
    let m = &ctx.members[0];
    let lines = match m.ty.name {
        "piston" => vec![m.named("mass", "mass"), m.named("stroke", "stroke")],
        "friction" => vec![format!("Eq. 37: k0 {}", m.show("k0"))],
        "spring" => vec![m.named("k", "stiffness"), m.named("preload", "preload")],
        "load" => vec![m.named("mass", "mass"), m.named("angle", "angle")],
        _ => vec![m.named("length", "cushion_length"), m.named("needle C", "C_needle")],
    };
    control::boxed(m, m.ty.name, &lines)
}
