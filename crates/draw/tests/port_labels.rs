//! The 5-port valves carry the ISO 5599-3 port names an engineer reads on a
//! real valve — P/1 supply, A/4 and B/2 working ports, R/5 and S/3 exhausts —
//! each written beside the pin of the netlist port it stands for (so A and B
//! swapped in the drawing code would fail here), and the shipped 5/2
//! circuit's diagram shows all five.

mod common;

use draw::shape::Prim;

const FIVE_PORTS: [(&str, &str); 5] = [("P", "P/1"), ("A", "A/4"), ("B", "B/2"), ("EA", "R/5"), ("EB", "S/3")];

#[test]
fn five_port_valves_name_each_port_beside_its_pin() {
    for name in ["valve_5_2", "valve_5_3", "proportional_valve"] {
        let ty = blocks::registry::block_type(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let shape = draw::catalogue::symbol_of(ty).unwrap().unwrap_or_else(|| panic!("{name}: no symbol"));
        for (port, label) in FIVE_PORTS {
            let (tx, ty_) = shape
                .prims
                .iter()
                .find_map(|p| match p {
                    Prim::Text { x, y, text, .. } if text == label => Some((*x, *y)),
                    _ => None,
                })
                .unwrap_or_else(|| panic!("{name}: no label {label}"));
            let nearest = shape
                .pins
                .iter()
                .min_by(|a, b| {
                    let d = |p: &draw::shape::Pin| (p.x - tx).powi(2) + (p.y - ty_).powi(2);
                    d(a).total_cmp(&d(b))
                })
                .expect("pins");
            assert_eq!(nearest.port, port, "{name}: {label} is written beside port {} instead of {port}", nearest.port);
        }
    }
}

#[test]
fn the_meter_out_diagram_shows_the_five_port_names() {
    let flat = graph::load(&common::Fs, &common::models().join("meter_out.json")).expect("meter_out loads");
    let svg = draw::diagram(&flat, None).expect("diagram").svg;
    let doc = roxmltree::Document::parse(&svg).expect("well-formed SVG");
    let texts: Vec<&str> = doc.descendants().filter(|n| n.has_tag_name("text")).filter_map(|n| n.text()).map(str::trim).collect();
    for (_, label) in FIVE_PORTS {
        assert!(texts.contains(&label), "meter_out's diagram lacks {label}: {texts:?}");
    }
}
