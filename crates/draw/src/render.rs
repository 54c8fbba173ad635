//! The SVG document: frames, symbols, lines (routed on the grid), exhaust
//! marks, labels and a title block with the circuit's name, description
//! and a legend. Working lines are solid black, pilot lines dashed black,
//! signal lines dashed blue with an arrowhead at each input.
//!
//! The document carries no script, no style sheet, no link and no id
//! attribute (so it can be inlined into a page without clashing with it);
//! every text goes through [`crate::svg::text`].

use crate::layout::{self, Layout, Rect};
use crate::route::{Grid, Routed, Terminal};
use crate::scene::{NetKind, Scene};
use crate::shape::{Anchor, Dir, Fill, PinKind, Prim, Shape, Stroke, G};
use crate::svg::{attr, num, shorten, text};
use std::fmt::Write;

const INK: &str = "#000";
const SIGNAL: &str = "#1d4f91";
const FRAME: &str = "#555";
const LABEL_INK: &str = "#1a1a1a";

/// Length of the line from a port to its exhaust triangle [px] (room for the port's name beside it).
const EXHAUST_STUB: f64 = 12.0;

/// Line styles of routed branches.
const WORKING: u8 = 0;
const PILOT: u8 = 1;
const SIGNAL_LINE: u8 = 2;
const MECHANICAL: u8 = 3;

/// Title, description and legend under the drawing.
pub struct TitleBlock<'a> {
    pub name: &'a str,
    pub description: Option<&'a str>,
    pub gas: &'a str,
}

fn stroke_attrs(stroke: Stroke, colour: &str) -> String {
    match stroke {
        Stroke::Solid => format!(r#"stroke="{colour}" stroke-width="1.4""#),
        Stroke::Thin => format!(r#"stroke="{colour}" stroke-width="0.9""#),
        Stroke::Dashed => format!(r#"stroke="{colour}" stroke-width="1.1" stroke-dasharray="5 3""#),
        Stroke::Chain => format!(r#"stroke="{colour}" stroke-width="0.9" stroke-dasharray="10 3 2 3""#),
        Stroke::None => r#"stroke="none""#.to_string(),
    }
}

fn fill_attr(fill: Fill, colour: &str) -> String {
    match fill {
        Fill::None => r#"fill="none""#.into(),
        Fill::Black => format!(r#"fill="{colour}""#),
        Fill::White => r##"fill="#fff""##.into(),
        Fill::Shade => r##"fill="#f2f2f2""##.into(),
    }
}

fn points(pts: &[(f64, f64)]) -> String {
    pts.iter().map(|(x, y)| format!("{},{}", num(*x), num(*y))).collect::<Vec<_>>().join(" ")
}

/// How a text is set.
#[derive(Clone, Copy)]
struct Font<'a> {
    size: f64,
    anchor: Anchor,
    bold: bool,
    italic: bool,
    colour: &'a str,
}

impl<'a> Font<'a> {
    fn plain(size: f64, colour: &'a str) -> Self {
        Font { size, anchor: Anchor::Start, bold: false, italic: false, colour }
    }
}

/// A text element, with a white outline behind it so that it reads over lines.
fn text_el(out: &mut String, x: f64, y: f64, s: &str, font: Font) {
    let Font { size, anchor, bold, italic, colour } = font;
    let anchor = match anchor {
        Anchor::Start => "",
        Anchor::Middle => r#" text-anchor="middle""#,
        Anchor::End => r#" text-anchor="end""#,
    };
    let weight = if bold { r#" font-weight="bold""# } else { "" };
    let style = if italic { r#" font-style="italic""# } else { "" };
    let _ = writeln!(
        out,
        r##"<text x="{}" y="{}" font-size="{}"{anchor}{weight}{style} fill="{colour}" stroke="#fff" stroke-width="2.5" stroke-linejoin="round" paint-order="stroke">{}</text>"##,
        num(x),
        num(y),
        num(size),
        text(s)
    );
}

/// A symbol's primitives, in its own coordinates.
pub fn prims(out: &mut String, prims: &[Prim], colour: &str) {
    for p in prims {
        match p {
            Prim::Polyline { pts, stroke } => {
                let _ = writeln!(
                    out,
                    r#"<polyline points="{}" fill="none" {} stroke-linejoin="round"/>"#,
                    points(pts),
                    stroke_attrs(*stroke, colour)
                );
            }
            Prim::Polygon { pts, stroke, fill } => {
                let _ =
                    writeln!(out, r#"<polygon points="{}" {} {}/>"#, points(pts), fill_attr(*fill, colour), stroke_attrs(*stroke, colour));
            }
            Prim::Rect { x, y, w, h, rx, stroke, fill } => {
                let rx = if *rx > 0.0 { format!(r#" rx="{}""#, num(*rx)) } else { String::new() };
                let _ = writeln!(
                    out,
                    r#"<rect x="{}" y="{}" width="{}" height="{}"{rx} {} {}/>"#,
                    num(*x),
                    num(*y),
                    num(*w),
                    num(*h),
                    fill_attr(*fill, colour),
                    stroke_attrs(*stroke, colour)
                );
            }
            Prim::Circle { cx, cy, r, stroke, fill } => {
                let _ = writeln!(
                    out,
                    r#"<circle cx="{}" cy="{}" r="{}" {} {}/>"#,
                    num(*cx),
                    num(*cy),
                    num(*r),
                    fill_attr(*fill, colour),
                    stroke_attrs(*stroke, colour)
                );
            }
            Prim::Arc { from, to, r, sweep, stroke } => {
                let _ = writeln!(
                    out,
                    r#"<path d="M{} {} A{} {} 0 0 {} {} {}" fill="none" {}/>"#,
                    num(from.0),
                    num(from.1),
                    num(*r),
                    num(*r),
                    u8::from(*sweep),
                    num(to.0),
                    num(to.1),
                    stroke_attrs(*stroke, colour)
                );
            }
            Prim::Text { x, y, text: t, size, anchor, bold, italic } => {
                text_el(out, *x, *y, t, Font { size: *size, anchor: *anchor, bold: *bold, italic: *italic, colour })
            }
        }
    }
}

/// A straight run of a line: style, from, to [px].
type Run = (u8, (f64, f64), (f64, f64));

/// Straight runs of a routed net by style.
fn runs(r: &Routed) -> Vec<Run> {
    let mut out = Vec::new();
    for style in [WORKING, PILOT, SIGNAL_LINE, MECHANICAL] {
        let mut horizontal: Vec<(i32, i32)> = Vec::new(); // (y, x) of a unit step starting at x
        let mut vertical: Vec<(i32, i32)> = Vec::new(); // (x, y)
        for &(a, b, s) in &r.segments {
            if s != style {
                continue;
            }
            if a.1 == b.1 {
                horizontal.push((a.1, a.0.min(b.0)));
            } else {
                vertical.push((a.0, a.1.min(b.1)));
            }
        }
        horizontal.sort_unstable();
        vertical.sort_unstable();
        let mut merge = |v: &[(i32, i32)], horizontal_run: bool| {
            let mut k = 0;
            while k < v.len() {
                let (line, start) = v[k];
                let mut end = start + 1;
                while k + 1 < v.len() && v[k + 1] == (line, end) {
                    end += 1;
                    k += 1;
                }
                let (a, b) = if horizontal_run {
                    ((start as f64 * G, line as f64 * G), (end as f64 * G, line as f64 * G))
                } else {
                    ((line as f64 * G, start as f64 * G), (line as f64 * G, end as f64 * G))
                };
                out.push((style, a, b));
                k += 1;
            }
        };
        merge(&horizontal, true);
        merge(&vertical, false);
    }
    out
}

/// Words of `s` in lines no wider than `max` px at `size`; at most `lines` lines.
fn wrap(s: &str, size: f64, max: f64, lines: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in s.split_whitespace() {
        let word = shorten(word, 80);
        let candidate = if current.is_empty() { word.clone() } else { format!("{current} {word}") };
        if crate::text::width(&candidate, size) > max && !current.is_empty() {
            out.push(std::mem::take(&mut current));
            current = word;
        } else {
            current = candidate;
        }
        if out.len() == lines {
            break;
        }
    }
    if !current.is_empty() && out.len() < lines {
        out.push(current);
    } else if out.len() == lines {
        if let Some(last) = out.last_mut() {
            last.push_str(" …");
        }
    }
    out
}

/// A symbol as placed: the blocks it draws and its body's rectangle [px].
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub ids: Vec<String>,
    pub kind: String,
    pub rect: Rect,
}

/// A net as drawn: its pins and its unit segments [px]; an exhaust net has
/// marks instead of segments.
#[derive(Debug, Clone, PartialEq)]
pub struct Drawn {
    pub kind: NetKind,
    pub exhaust: bool,
    pub pins: Vec<(f64, f64)>,
    pub segments: Vec<((f64, f64), (f64, f64))>,
}

/// The document with what it shows.
pub struct Document {
    pub svg: String,
    pub width: f64,
    pub height: f64,
    pub placed: Vec<Placed>,
    pub nets: Vec<Drawn>,
}

/// The whole SVG document.
pub fn document(scene: &Scene, title: &TitleBlock) -> Document {
    let lay: Layout = layout::place(scene);
    let (w, h) = (lay.extent.w.max(60.0 * G), lay.extent.h);
    let mut grid = Grid::new(w, h);
    let abs = |i: usize, x: f64, y: f64| (lay.pos[i].0 + x, lay.pos[i].1 + y);
    for (i, item) in scene.items.iter().enumerate() {
        let (x, y) = lay.pos[i];
        grid.wall(&Rect { x, y, w: item.shape.w, h: item.shape.h });
        grid.soft(&lay.label[i].grow(4.0));
    }
    for (r, t) in &lay.frames {
        grid.soft(&Rect { x: r.x, y: r.y, w: crate::text::width(t, 8.5) + 8.0, h: 14.0 });
    }

    // exhaust marks, and the terminals of every other net
    let mut marks = Shape::default();
    let mut terminals: Vec<Vec<Terminal>> = Vec::with_capacity(scene.nets.len());
    for net in &scene.nets {
        let mut ts = Vec::new();
        for p in &net.pins {
            let pin = &scene.items[p.item].shape.pins[p.pin];
            let (x, y) = abs(p.item, pin.x, pin.y);
            let at = ((x / G).round() as i32, (y / G).round() as i32);
            if net.exhaust.is_some() {
                marks.exhaust(x, y, pin.dir, EXHAUST_STUB);
                let (dx, dy) = pin.dir.step();
                for k in 1..=3 {
                    grid.block((at.0 + dx * k, at.1 + dy * k));
                }
                continue;
            }
            let style = match (net.kind, pin.kind) {
                (NetKind::Signal, _) => SIGNAL_LINE,
                (NetKind::Mechanical, _) => MECHANICAL,
                (_, PinKind::Pilot) => PILOT,
                _ => WORKING,
            };
            ts.push((style, scene.items[p.item].kind != "pressure_source", Terminal { at, dir: pin.dir, style }));
        }
        // working pins first (the supply first of all), then pilot branches
        ts.sort_by_key(|(style, not_source, _)| (*style, *not_source));
        terminals.push(ts.into_iter().map(|(_, _, t)| t).collect());
    }
    for (k, ts) in terminals.iter().enumerate() {
        for t in ts {
            grid.reserve(t, k);
        }
    }
    let mut order: Vec<usize> = (0..scene.nets.len()).filter(|&k| terminals[k].len() >= 2).collect();
    let span = |k: usize| -> i32 {
        let ts = &terminals[k];
        let (x0, x1) = (ts.iter().map(|t| t.at.0).min().unwrap_or(0), ts.iter().map(|t| t.at.0).max().unwrap_or(0));
        let (y0, y1) = (ts.iter().map(|t| t.at.1).min().unwrap_or(0), ts.iter().map(|t| t.at.1).max().unwrap_or(0));
        (x1 - x0) + (y1 - y0)
    };
    order.sort_by_key(|&k| (scene.nets[k].kind == NetKind::Signal, span(k), k));
    let mut routed: Vec<(usize, Routed)> = order.iter().map(|&k| (k, grid.route(k, &terminals[k]))).collect();
    routed.sort_by_key(|(k, _)| *k);

    // ---- the document ----
    let description_lines = title.description.map(|d| wrap(d, 9.5, w - 4.0 * G, 5)).unwrap_or_default();
    let block_h = 2.0 * G + 16.0 + description_lines.len() as f64 * 12.5 + 48.0;
    let total_h = h + block_h;
    let mut out = String::new();
    let _ = writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{}" height="{}" viewBox="0 0 {} {}" font-family="{}">"#,
        num(w),
        num(total_h),
        num(w),
        num(total_h),
        attr(crate::text::FAMILY)
    );
    let _ = writeln!(out, "<title>{}</title>", text(&format!("{} — pneumatic circuit diagram (ISO 1219-1 symbols)", title.name)));
    let _ = writeln!(out, r##"<rect x="0" y="0" width="{}" height="{}" fill="#fff"/>"##, num(w), num(total_h));

    // subsystem frames
    for (r, t) in &lay.frames {
        let _ = writeln!(
            out,
            r#"<rect x="{}" y="{}" width="{}" height="{}" fill="none" {}/>"#,
            num(r.x),
            num(r.y),
            num(r.w),
            num(r.h),
            stroke_attrs(Stroke::Chain, FRAME)
        );
        text_el(&mut out, r.x + 4.0, r.y + 11.0, &shorten(t, 90), Font { italic: true, ..Font::plain(8.5, FRAME) });
    }

    // lines
    let _ = writeln!(out, r#"<g fill="none" stroke-linecap="square">"#);
    for (_, r) in &routed {
        for (style, a, b) in runs(r) {
            let (stroke, colour) = match style {
                PILOT => (Stroke::Dashed, INK),
                SIGNAL_LINE => (Stroke::Dashed, SIGNAL),
                MECHANICAL => (Stroke::Thin, INK),
                _ => (Stroke::Solid, INK),
            };
            let width = if style == WORKING { r#" stroke-width="1.6""# } else { "" };
            let attrs = stroke_attrs(stroke, colour);
            let attrs = if width.is_empty() { attrs } else { attrs.replace(r#"stroke-width="1.4""#, width.trim()) };
            let _ = writeln!(out, r#"<path d="M{} {}L{} {}" {attrs}/>"#, num(a.0), num(a.1), num(b.0), num(b.1));
        }
    }
    let _ = writeln!(out, "</g>");
    for (k, r) in &routed {
        let colour = if scene.nets[*k].kind == NetKind::Signal { SIGNAL } else { INK };
        for p in &r.junctions {
            let _ = writeln!(out, r#"<circle cx="{}" cy="{}" r="2.6" fill="{colour}"/>"#, num(p.0 as f64 * G), num(p.1 as f64 * G));
        }
    }
    // arrowheads at signal inputs
    let mut heads = Shape::default();
    for net in scene.nets.iter().filter(|n| n.kind == NetKind::Signal) {
        for p in &net.pins {
            let pin = &scene.items[p.item].shape.pins[p.pin];
            if pin.kind != PinKind::SignalIn {
                continue;
            }
            let (x, y) = abs(p.item, pin.x, pin.y);
            let (dx, dy) = pin.dir.step();
            let from = (x + f64::from(dx) * 8.0, y + f64::from(dy) * 8.0);
            heads.arrowhead(from, (x, y), 6.0, Fill::Black);
        }
    }
    prims(&mut out, &heads.prims, SIGNAL);

    // symbols
    for (i, item) in scene.items.iter().enumerate() {
        let (x, y) = lay.pos[i];
        let colour = if item.role == crate::scene::Role::Control { SIGNAL } else { INK };
        let _ = writeln!(out, r#"<g transform="translate({} {})">"#, num(x), num(y));
        let _ = writeln!(out, "<title>{}</title>", text(&shorten(&format!("{} ({})", item.ids.join(", "), item.kind), 300)));
        prims(&mut out, &item.shape.prims, colour);
        let _ = writeln!(out, "</g>");
    }
    prims(&mut out, &marks.prims, INK);

    // labels
    for (i, item) in scene.items.iter().enumerate() {
        let r = lay.label[i];
        if r.w <= 0.0 {
            continue;
        }
        text_el(&mut out, r.x, r.y + 9.5, &shorten(&item.display, 60), Font { bold: true, ..Font::plain(layout::ID_SIZE, LABEL_INK) });
        for (k, line) in item.shape.label.iter().enumerate() {
            let ly = r.y + 9.5 + layout::LABEL_LINE * (k as f64 + 1.0);
            text_el(&mut out, r.x, ly, &shorten(line, 70), Font::plain(layout::PARAM_SIZE, LABEL_INK));
        }
    }

    // title block
    let top = h;
    let _ = writeln!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{FRAME}" stroke-width="0.8"/>"#,
        num(G),
        num(top),
        num(w - G),
        num(top)
    );
    let mut ty = top + 2.0 * G;
    text_el(&mut out, 2.0 * G, ty, &shorten(title.name, 100), Font { bold: true, ..Font::plain(13.0, INK) });
    text_el(&mut out, w - 2.0 * G, ty, &format!("gas: {}", title.gas), Font { anchor: Anchor::End, ..Font::plain(9.0, FRAME) });
    ty += 6.0;
    for line in &description_lines {
        ty += 12.5;
        text_el(&mut out, 2.0 * G, ty, line, Font::plain(9.5, LABEL_INK));
    }
    ty += 20.0;
    let vents: Vec<&str> = scene.exhausts.values().map(String::as_str).collect();
    legend(&mut out, 2.0 * G, ty, &vents);
    let _ = writeln!(out, "</svg>");
    let placed = scene
        .items
        .iter()
        .enumerate()
        .map(|(i, item)| Placed {
            ids: item.ids.clone(),
            kind: item.kind.clone(),
            rect: Rect { x: lay.pos[i].0, y: lay.pos[i].1, w: item.shape.w, h: item.shape.h },
        })
        .collect();
    let px = |p: (i32, i32)| (f64::from(p.0) * G, f64::from(p.1) * G);
    let nets = scene
        .nets
        .iter()
        .enumerate()
        .map(|(k, net)| Drawn {
            kind: net.kind,
            exhaust: net.exhaust.is_some(),
            pins: net
                .pins
                .iter()
                .map(|p| {
                    let pin = &scene.items[p.item].shape.pins[p.pin];
                    abs(p.item, pin.x, pin.y)
                })
                .collect(),
            segments: routed
                .iter()
                .find(|(j, _)| *j == k)
                .map(|(_, r)| r.segments.iter().map(|&(a, b, _)| (px(a), px(b))).collect())
                .unwrap_or_default(),
        })
        .collect();
    Document { svg: out, width: w, height: total_h, placed, nets }
}

/// One line of legend: line styles, exhaust, port names, units.
fn legend(out: &mut String, x0: f64, y: f64, vents: &[&str]) {
    let mut x = x0;
    let sample = |out: &mut String, x: f64, stroke: Stroke, colour: &str| {
        let _ = writeln!(out, r#"<path d="M{} {}H{}" fill="none" {}/>"#, num(x), num(y - 3.0), num(x + 24.0), stroke_attrs(stroke, colour));
    };
    sample(out, x, Stroke::Solid, INK);
    let legend = Font::plain(8.5, LABEL_INK);
    text_el(out, x + 28.0, y, "working line", legend);
    x += 100.0;
    sample(out, x, Stroke::Dashed, INK);
    text_el(out, x + 28.0, y, "pilot line", legend);
    x += 82.0;
    sample(out, x, Stroke::Dashed, SIGNAL);
    text_el(out, x + 28.0, y, "signal line", legend);
    x += 90.0;
    let mut s = Shape::default();
    s.exhaust(x + 6.0, y - 12.0, Dir::Down, 3.0);
    prims(out, &s.prims, INK);
    let vent = if vents.is_empty() { "exhaust".to_string() } else { format!("exhaust to atmosphere: {}", vents.join(", ")) };
    text_el(out, x + 18.0, y, &shorten(&vent, 120), legend);
    text_el(
        out,
        x0,
        y + 14.0,
        "ports: P/1 supply · A/4, B/2 working · R/5, S/3 exhaust · 14, 12 actuators · pressures absolute (gauge in brackets)",
        legend,
    );
}
