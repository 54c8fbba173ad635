//! Every registered block type has a symbol of its own, with a pin for
//! every port of the block, and the symbol sheet shows them all.

use blocks::registry::TYPES;

#[test]
fn every_registered_block_type_has_a_symbol_with_a_pin_per_port() {
    assert!(TYPES.len() >= 35, "the registry lists {} types", TYPES.len());
    for ty in TYPES {
        let shape = draw::catalogue::symbol_of(ty).unwrap().unwrap_or_else(|| panic!("{}: no symbol", ty.name));
        let raw = draw::catalogue::sample(ty);
        let block = blocks::registry::build(ty.name, raw.iter().map(|(k, v)| (*k, v))).unwrap();
        for port in block.ports() {
            assert!(shape.pins.iter().any(|p| p.port == port.name), "{}: port {} has no pin", ty.name, port.name);
        }
        assert!(shape.prims.len() >= 2, "{}: an empty symbol", ty.name);
        assert!(shape.w > 0.0 && shape.h > 0.0);
        // pins lie on the grid and on the body's edge, so lines meet them exactly
        for pin in &shape.pins {
            let g = draw::shape::G;
            assert_eq!((pin.x % g, pin.y % g), (0.0, 0.0), "{}: pin {} off the grid", ty.name, pin.port);
            let on_edge = pin.x == 0.0 || pin.y == 0.0 || pin.x == shape.w || pin.y == shape.h;
            assert!(on_edge, "{}: pin {} inside the body", ty.name, pin.port);
        }
    }
}

#[test]
fn symbols_of_different_types_differ() {
    // no type falls back to a shared placeholder: each symbol's drawing is its own
    let mut seen: Vec<(String, &str)> = Vec::new();
    for ty in TYPES {
        let shape = draw::catalogue::symbol_of(ty).unwrap().unwrap();
        let drawing = format!("{:?}", shape.prims);
        if let Some((_, other)) = seen.iter().find(|(d, _)| *d == drawing) {
            panic!("{} and {} are drawn alike", ty.name, other);
        }
        seen.push((drawing, ty.name));
    }
}

#[test]
fn the_symbol_sheet_names_every_type_and_renders() {
    let sheet = draw::catalogue::catalogue().unwrap();
    roxmltree::Document::parse(&sheet.svg).expect("well-formed SVG");
    for ty in TYPES {
        assert!(sheet.svg.contains(&format!(">{}</text>", ty.name)), "{} missing from the sheet", ty.name);
    }
    let png = draw::png(&sheet.svg, 1.0).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}
