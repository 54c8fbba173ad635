//! The shipped circuits drawn: every model renders into well-formed SVG
//! and PNG, deterministically; its lines join exactly the pins they should,
//! never share a run with another line and never cross a symbol; five
//! circuits are compared with golden files and checked for the layout a
//! pneumatics engineer expects (supply at the bottom, cylinders on top,
//! the flow control in the line it throttles).
//!
//! Golden files: `crates/draw/tests/golden/*.svg`. After an intended change
//! of the drawing, look at the new pictures, then rewrite the files with
//! `PNEUMO_UPDATE_GOLDEN=1 cargo test -p pneumo-draw --test circuits`.

use draw::render::Placed;
use draw::scene::NetKind;
use std::collections::{BTreeMap, BTreeSet};
mod common;
use common::{models, Fs};
use std::path::{Path, PathBuf};

fn draw_file(path: &Path) -> draw::Diagram {
    let flat = graph::load(&Fs, path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = std::fs::read_to_string(path).unwrap();
    let description = graph::expand::parse(&text, "m").unwrap().description;
    draw::diagram(&flat, description.as_deref()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn shipped() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(models())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("json"))
        .collect();
    v.sort();
    v
}

type Pt = (i64, i64);

fn key(p: (f64, f64)) -> Pt {
    (p.0.round() as i64, p.1.round() as i64)
}

/// The checks every drawing must pass.
fn check(name: &str, d: &draw::Diagram) {
    roxmltree::Document::parse(&d.svg).unwrap_or_else(|e| panic!("{name}: not well-formed: {e}"));
    let mut owner: BTreeMap<(Pt, Pt), usize> = BTreeMap::new();
    for (k, net) in d.nets.iter().enumerate() {
        if net.exhaust {
            assert!(net.segments.is_empty(), "{name}: an exhaust is drawn as marks");
            continue;
        }
        // the segments form one connected tree through every pin
        let mut adj: BTreeMap<Pt, Vec<Pt>> = BTreeMap::new();
        for &(a, b) in &net.segments {
            let (a, b) = (key(a), key(b));
            adj.entry(a).or_default().push(b);
            adj.entry(b).or_default().push(a);
            let e = if a < b { (a, b) } else { (b, a) };
            if let Some(other) = owner.insert(e, k) {
                assert_eq!(other, k, "{name}: nets {other} and {k} share the segment {e:?}");
            }
        }
        let pins: Vec<Pt> = net.pins.iter().map(|&p| key(p)).collect();
        let mut seen = BTreeSet::from([pins[0]]);
        let mut stack = vec![pins[0]];
        while let Some(p) = stack.pop() {
            for &q in adj.get(&p).into_iter().flatten() {
                if seen.insert(q) {
                    stack.push(q);
                }
            }
        }
        for p in &pins {
            assert!(seen.contains(p), "{name}: net {k} ({:?}) does not reach its pin at {p:?}", net.kind);
        }
        // no line runs through a symbol's body (it may end on its edge, at a pin)
        for &(a, b) in &net.segments {
            let mid = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
            for s in &d.placed {
                let r = &s.rect;
                let inside = mid.0 > r.x + 0.5 && mid.0 < r.x + r.w - 0.5 && mid.1 > r.y + 0.5 && mid.1 < r.y + r.h - 0.5;
                assert!(!inside, "{name}: net {k} runs through {:?} at {mid:?}", s.ids);
            }
        }
    }
}

#[test]
fn every_shipped_model_is_drawn_and_its_lines_join_their_pins() {
    let models = shipped();
    assert!(models.len() >= 13);
    for path in models {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let d = draw_file(&path);
        check(&name, &d);
        // the same netlist gives the same bytes
        assert_eq!(d.svg, draw_file(&path).svg, "{name}: not deterministic");
        let png = draw::png(&d.svg, 1.0).unwrap();
        assert_eq!(&png[1..4], b"PNG", "{name}");
        // every block appears in a symbol's tooltip (atmospheres as exhaust marks)
        let flat = graph::load(&Fs, &path).unwrap();
        for c in &flat.components {
            if c.kind == "atmosphere" {
                continue;
            }
            assert!(d.placed.iter().any(|s| s.ids.contains(&c.id)), "{name}: {} is not drawn", c.id);
        }
    }
}

fn find<'a>(d: &'a draw::Diagram, id: &str) -> &'a Placed {
    d.placed.iter().find(|s| s.ids.iter().any(|i| i == id)).unwrap_or_else(|| panic!("no symbol for {id}"))
}

fn centre_x(s: &Placed) -> f64 {
    s.rect.x + s.rect.w / 2.0
}

fn above(a: &Placed, b: &Placed) -> bool {
    a.rect.y + a.rect.h <= b.rect.y
}

fn golden(name: &str, d: &draw::Diagram) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(format!("{name}.svg"));
    if std::env::var_os("PNEUMO_UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &d.svg).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e} (write it with PNEUMO_UPDATE_GOLDEN=1)", path.display()));
    assert!(want == d.svg, "{name}: the drawing differs from {}; look at it, then PNEUMO_UPDATE_GOLDEN=1 if intended", path.display());
}

#[test]
fn meter_out_reads_as_the_papers_circuit() {
    let d = draw_file(&models().join("meter_out.json"));
    golden("meter_out", &d);
    let (cyl, fc, dcv, supply) = (find(&d, "piston"), find(&d, "flow_control"), find(&d, "dcv"), find(&d, "supply"));
    assert_eq!(cyl.kind, "cylinder");
    assert!(cyl.ids.iter().any(|i| i == "head") && cyl.ids.iter().any(|i| i == "rod") && cyl.ids.iter().any(|i| i == "friction"));
    // energy flows upwards: supply, valve, flow control, cylinder
    assert!(above(cyl, fc) && above(fc, dcv) && above(dcv, supply), "{:?}", d.placed);
    // the flow control sits in the rod-side line: right of the valve's centre, under the rod end
    assert!(centre_x(fc) > centre_x(dcv));
    for text in ["A/4", "B/2", "P/1", "R/5", "S/3", "13.2 L/min/bar", "Ø45/15 × 450 mm", "4 bar (2.99 barg)", "free a→b, throttled b→a"]
    {
        assert!(d.svg.contains(&format!(">{text}<")) || d.svg.contains(text), "meter_out: no \"{text}\"");
    }
    // the valve's two exhausts vent to atmosphere, the cycler is joined by signal lines
    assert_eq!(d.nets.iter().filter(|n| n.exhaust).map(|n| n.pins.len()).sum::<usize>(), 2);
    assert_eq!(d.nets.iter().filter(|n| n.kind == NetKind::Signal).count(), 2);
}

#[test]
fn meter_in_puts_the_flow_control_in_the_head_line() {
    let d = draw_file(&models().join("meter_in.json"));
    golden("meter_in", &d);
    let (cyl, fc, dcv) = (find(&d, "cyl.piston"), find(&d, "flow_control"), find(&d, "dcv"));
    assert!(above(cyl, fc) && above(fc, dcv));
    assert!(centre_x(fc) < centre_x(dcv), "the head line leaves the valve's A/4 port on the left");
    // turned over: its free direction a -> b points down, from the cylinder to the valve
    let pins: Vec<(f64, f64)> = d.nets.iter().filter(|n| !n.exhaust).flat_map(|n| n.pins.clone()).collect();
    assert!(pins.iter().any(|p| (p.1 - fc.rect.y).abs() < 0.5) && pins.iter().any(|p| (p.1 - fc.rect.y - fc.rect.h).abs() < 0.5));
    assert!(d.svg.contains("subsystem lib:cylinder"));
}

#[test]
fn mid_stop_shows_a_closed_centre_valve_between_supply_and_cylinder() {
    let d = draw_file(&models().join("mid_stop_5_3.json"));
    golden("mid_stop_5_3", &d);
    let (cyl, valve, supply) = (find(&d, "cyl.piston"), find(&d, "valve"), find(&d, "supply"));
    assert!(above(cyl, valve) && above(valve, supply));
    assert!(d.svg.contains("5/3 closed centre, solenoid, spring-centred"));
    // both solenoids are driven by their schedules, from the control column on the left
    for s in ["sol_14", "sol_12"] {
        assert!(find(&d, s).rect.x + find(&d, s).rect.w < valve.rect.x);
    }
    assert!(d.svg.contains(">14<") && d.svg.contains(">12<"));
}

#[test]
fn sequence_ab_has_one_column_per_cylinder() {
    let d = draw_file(&models().join("sequence_ab.json"));
    golden("sequence_ab", &d);
    let (a, b) = (find(&d, "cyl_a.piston"), find(&d, "cyl_b.piston"));
    let (va, vb) = (find(&d, "valve_a"), find(&d, "valve_b"));
    assert_eq!(a.rect.y, b.rect.y, "cylinders share the top row");
    assert!(centre_x(a) < centre_x(b) && centre_x(va) < centre_x(vb));
    assert!(above(a, va) && above(b, vb));
    // each valve stands under its own cylinder: its column overlaps the cylinder's, not the other's
    let overlaps = |p: &Placed, q: &Placed| p.rect.x < q.rect.x + q.rect.w && q.rect.x < p.rect.x + p.rect.w;
    assert!(overlaps(va, a) && !overlaps(va, b) && overlaps(vb, b) && !overlaps(vb, a));
    // the limit switches are drawn on their cylinders
    for (s, cyl) in [("a0", a), ("a1", a), ("b0", b), ("b1", b)] {
        assert!(cyl.ids.iter().any(|i| i == s), "{s} is not on its cylinder");
    }
    // one supply feeds both valves: a junction on its line
    let supply = find(&d, "supply");
    assert!(above(va, supply) && above(vb, supply));
    assert!(d.svg.contains("0 → 1 : start &amp; a0 &amp; b0"), "the GRAFCET is written out");
}

#[test]
fn position_control_closes_the_loop_through_the_pid() {
    let d = draw_file(&models().join("position_control.json"));
    golden("position_control", &d);
    let (cyl, valve, pid) = (find(&d, "cyl.piston"), find(&d, "valve"), find(&d, "controller"));
    assert!(above(cyl, valve));
    assert!(cyl.ids.iter().any(|i| i == "sensor"), "the position sensor is drawn on the rod");
    assert!(pid.rect.x + pid.rect.w < valve.rect.x, "the PID stands in the control column");
    assert!(d.svg.contains("proportional 5/3, zero lap"));
    // three signal lines: setpoint -> PID, sensor -> PID, PID -> valve
    assert_eq!(d.nets.iter().filter(|n| n.kind == NetKind::Signal).count(), 3);
}
