//! A diagram is safe to mail around: text from a netlist — its name,
//! description, parameter descriptions, the file names of its subsystems —
//! is escaped, so markup in it stays text. A hostile netlist is drawn and
//! the SVG parsed: it holds only drawing elements, no script, no event
//! handler, no link, and the hostile strings appear as text.

mod common;
use common::Fs;
use std::path::PathBuf;

const SCRIPT: &str = "<script>alert('pwned')</script>";

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pneumo-draw-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("lib")).unwrap();
    dir
}

/// Elements a diagram may contain.
const ALLOWED: &[&str] = &["svg", "title", "g", "rect", "line", "polyline", "polygon", "circle", "path", "text"];

fn assert_inert(svg: &str) {
    let doc = roxmltree::Document::parse(svg).expect("well-formed");
    for node in doc.descendants().filter(|n| n.is_element()) {
        let tag = node.tag_name().name();
        assert!(ALLOWED.contains(&tag), "unexpected element <{tag}>");
        for a in node.attributes() {
            let name = a.name().to_ascii_lowercase();
            assert!(!name.starts_with("on") && !name.contains("href") && name != "style", "attribute {name} on <{tag}>");
            assert!(!a.value().to_ascii_lowercase().contains("javascript:"), "{name}={}", a.value());
        }
    }
    for bad in ["<script", "<img", "<foreignObject", "<a ", "<style"] {
        assert!(!svg.contains(bad), "raw {bad} in the SVG");
    }
}

#[test]
fn markup_from_the_netlist_stays_text() {
    let dir = scratch("hostile");
    let sub_name = "lib/<img src=x onerror=alert(1)>.json";
    let sub = r#"{"name": "x", "description": "<b>inner</b>",
        "parameters": {"bore": {"value": "32 mm", "description": "</text><script>alert(2)</script>"}},
        "components": [
            {"id": "head", "type": "chamber", "params": {"dead_volume": "5 cm3", "bore": "= bore"}},
            {"id": "piston", "type": "piston", "params": {"mass": "1 kg", "stroke": "100 mm"}},
            {"id": "orifice", "type": "conductance", "params": {"C": "10 L/min/bar", "b": 0.3}}
        ],
        "connections": [["head.piston", "piston.rod"], ["head.port", "orifice.b"]],
        "interface": {"ports": {"in": "orifice.a"}}}"#;
    std::fs::write(dir.join(sub_name), sub).unwrap();
    let top = format!(
        r#"{{"name": {name}, "description": {desc},
        "parameters": {{"p": {{"value": "3 bar", "description": {desc}}}}},
        "components": [
            {{"id": "supply", "type": "pressure_source", "params": {{"p": "= p"}}}},
            {{"id": "cyl", "type": "subsystem", "file": {file}}}
        ],
        "connections": [["supply.port", "cyl.in"]]}}"#,
        name = serde_json::to_string(&format!("{SCRIPT}<svg onload=alert(3)>")).unwrap(),
        desc = serde_json::to_string(&format!("]]> & \u{1}\u{202e} </title>{SCRIPT} <a href=\"javascript:alert(4)\">x</a>")).unwrap(),
        file = serde_json::to_string(sub_name).unwrap(),
    );
    let path = dir.join("top.json");
    std::fs::write(&path, &top).unwrap();
    let flat = graph::load(&Fs, &path).unwrap();
    let description = graph::expand::parse(&top, "top.json").unwrap().description;
    let d = draw::diagram(&flat, description.as_deref()).unwrap();
    assert_inert(&d.svg);
    // the hostile text is there, as text
    let doc = roxmltree::Document::parse(&d.svg).unwrap();
    let texts: Vec<String> = doc.descendants().filter(|n| n.is_text()).map(|n| n.text().unwrap_or("").to_string()).collect();
    assert!(texts.iter().any(|t| t.contains(SCRIPT)), "the name is shown as text");
    assert!(texts.iter().any(|t| t.contains("<img src=x onerror=alert(1)>")), "the subsystem file is shown as text: {texts:?}");
    assert!(!texts.iter().any(|t| t.contains('\u{1}') || t.contains('\u{202e}')), "control characters are dropped");
    // it renders
    let png = draw::png(&d.svg, 1.0).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_id_with_markup_is_refused_before_drawing() {
    let dir = scratch("badid");
    let path = dir.join("m.json");
    std::fs::write(
        &path,
        r#"{"name": "m", "components": [{"id": "<script>x</script>", "type": "pressure_source", "params": {"p": "3 bar"}}]}"#,
    )
    .unwrap();
    let e = graph::load(&Fs, &path).unwrap_err().to_string();
    assert!(e.contains("may contain only letters"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
