//! `pneumo linearize --at` with trim conditions (issue 25): the conditions
//! are read in their units against the model's names, the linear model is
//! about the trimmed point, and a condition that names nothing, has the
//! wrong dimension or cannot be met is one clear error naming it.

use pneumo_app::linearize::{linearize, LinearizeOptions};
use std::path::{Path, PathBuf};

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/examples/linearize/paper_cylinder_mid_stroke.json")
}

fn at(text: &str) -> Result<pneumo_app::linearize::Linearized, String> {
    linearize(&LinearizeOptions { model: model(), at: text.to_string(), ..Default::default() }).map_err(|e| e.to_string())
}

#[test]
fn trim_conditions_in_units_give_the_linear_model_about_the_trimmed_point() {
    let r = at("piston.x=200 mm; F=0 N; head.p=4 bar").unwrap_or_else(|e| panic!("{e}"));
    let op = &r.json["operating_point"];
    assert_eq!(op["kind"], "trim");
    let k = r.model.outputs.iter().position(|o| o.name == "x").expect("output x");
    assert!((r.model.y0[k] - 0.2).abs() < 1e-12, "x = {} m", r.model.y0[k]);
    // at an equilibrium every kept state's rate is zero
    for (s, dx) in r.model.states.iter().zip(&r.model.dx0) {
        assert!(dx.abs() < 1e-6, "d{}/dt = {dx:e}", s.name);
    }
    let held = r.json["trim"]["held"].as_array().expect("trim.held");
    let names: Vec<&str> = held.iter().map(|h| h["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["piston.x", "F", "head.p"]);
    assert_eq!(held[2]["value"], 4e5);
    assert!(r.json["trim"]["residual"].as_f64().unwrap() < 1e-10);
    let text = pneumo_app::linearize::text(&r);
    assert!(text.contains("held piston.x = 0.2 m, F = 0 N, head.p = 400000 Pa"), "{text}");
    // commas separate conditions too
    let again = at("piston.x = 200 mm, F = 0 N, head.p = 4 bar").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.model.a.to_rows(), r.model.a.to_rows());
}

#[test]
fn a_bad_trim_condition_is_one_error_naming_it() {
    let cases: [(&str, &[&str]); 5] = [
        ("piston.y=200 mm; F=0 N; head.p=4 bar", &["piston.y", "no state, interface input or recorded value"]),
        ("piston.x=200 bar; F=0 N; head.p=4 bar", &["piston.x=200 bar", "bar"]),
        ("piston.x=200 mm; F; head.p=4 bar", &["\"F\" is not NAME=VALUE"]),
        ("piston.x=200 mm", &["under-determined", "head.m", "rod.m", "F"]),
        ("piston.x=600 mm; F=0 N; head.p=4 bar", &["piston.x = 0.6 m", "cannot be evaluated"]),
    ];
    for (text, wanted) in cases {
        let e = at(text).err().unwrap_or_else(|| panic!("{text}: accepted"));
        assert_eq!(e.lines().count(), 1, "{text}: {e}");
        for w in wanted {
            assert!(e.contains(w), "{text}: {e} (wanted {w})");
        }
    }
}
