//! `pneumo draw` end to end: SVG and PNG written together, `--set` reaches
//! the labels, bad requests are one-line errors that write nothing, and an
//! output never overwrites the netlist.

mod common;
use common::{pneumo_in, repo, Scratch, PNG_MAGIC};

#[test]
fn draws_svg_and_png_together_with_overrides_in_the_labels() {
    let dir = Scratch::new("draw");
    let model = repo().join("models/meter_out.json");
    let (svg, png) = (dir.path("c.svg"), dir.path("c.png"));
    let out = pneumo_in(
        &dir.0,
        &[
            "draw",
            model.to_str().unwrap(),
            "--set",
            "flow_control.C=2.68 L/min/bar",
            "--out",
            svg.to_str().unwrap(),
            "--out",
            png.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<?xml") && text.contains("throttle C 2.68 L/min/bar"), "the override shows in the label");
    assert!(std::fs::read(&png).unwrap().starts_with(PNG_MAGIC));
}

#[test]
fn refuses_bad_outputs_and_writes_nothing() {
    let dir = Scratch::new("draw-bad");
    let model = dir.write("m.json", &std::fs::read_to_string(repo().join("models/tank_discharge.json")).unwrap());
    let svg = dir.path("ok.svg");
    // an unknown format: nothing is written, not even the good output
    let out = pneumo_in(&dir.0, &["draw", "m.json", "--out", svg.to_str().unwrap(), "--out", "x.txt"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(".svg or .png") && err.lines().count() == 1, "{err}");
    assert!(!svg.exists());
    // the netlist itself is never overwritten
    let before = std::fs::read(&model).unwrap();
    let out = pneumo_in(&dir.0, &["draw", "m.json", "--out", "m.json.svg", "--out", "./m.json"]);
    assert_ne!(out.status.code(), Some(0));
    assert_eq!(std::fs::read(&model).unwrap(), before);
    // a netlist that does not build is reported like `pneumo check` reports it
    dir.write(
        "broken.json",
        r#"{"name": "b", "components": [{"id": "v", "type": "valve_3_2", "params": {"C": "1 L/min/bar", "b": 0.3}}]}"#,
    );
    let out = pneumo_in(&dir.0, &["draw", "broken.json", "--out", "b.svg"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not connected"), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!dir.path("b.svg").exists());
}
