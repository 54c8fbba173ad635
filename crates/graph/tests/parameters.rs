//! Named parameters and expressions through the public path a netlist takes:
//! text → `graph::load` (subsystems) → `graph::apply_set` → `graph::build`
//! (resolution). Each test names what a user would have done wrong, or
//! what must move when a value it depends on moves.

use graph::netlist::Value;
use graph::{FlatNetlist, Loader};
use serde_json::{json, Value as Json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Default)]
struct MemLoader(BTreeMap<PathBuf, String>);

impl Loader for MemLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        self.0.get(path).cloned().ok_or_else(|| format!("no such file {}", path.display()))
    }
}

fn load_with(files: &[(&str, Json)]) -> Result<FlatNetlist, String> {
    let loader = MemLoader(files.iter().map(|(p, j)| (PathBuf::from(p), j.to_string())).collect());
    graph::load(&loader, Path::new(files[0].0)).map_err(|e| e.to_string())
}

/// A tank filled through a conductance from a supply, with the given
/// top-level parameters and tank parameters.
fn tank(parameters: Json, tank_params: Json, tank_init: Json) -> Json {
    json!({
        "name": "tank",
        "parameters": parameters,
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar", "T": "293.15 K" } },
            { "id": "valve", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "tank", "type": "chamber", "params": tank_params, "init": tank_init }
        ],
        "connections": [["supply.port", "valve.a"], ["valve.b", "tank.port"]]
    })
}

fn si(c: &graph::Circuit, name: &str) -> f64 {
    c.resolved.get(name).unwrap_or_else(|| panic!("{name} not resolved")).si
}

fn build(flat: &FlatNetlist) -> Result<graph::Circuit, String> {
    graph::build(flat).map_err(|e| e.to_string())
}

fn assert_names(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "message does not name {p:?}: {message}");
    }
    assert!(!message.contains('\n'), "message spans several lines: {message}");
}

#[test]
fn expressions_follow_the_parameters_they_name() {
    let n = tank(
        json!({ "V_port": "0.5 L", "k": { "value": 3, "description": "volume factor" } }),
        json!({ "dead_volume": "= k * V_port - 0.25 L" }),
        json!({ "p0": "= supply.p / 2", "T0": "= supply.T + 10 K" }),
    );
    let flat = load_with(&[("m.json", n)]).unwrap();
    let c = build(&flat).unwrap();
    assert!((si(&c, "tank.dead_volume") - 1.25e-3).abs() < 1e-15);
    assert!((si(&c, "tank.p0") - 3e5).abs() < 1e-9);
    assert!((si(&c, "tank.T0") - 303.15).abs() < 1e-12);
    assert!(c.resolved.get("tank.p0").unwrap().derived());
    assert!(!c.resolved.get("supply.p").unwrap().derived());
    assert_eq!(si(&c, "k"), 3.0);
}

#[test]
fn set_moves_everything_that_depends_on_the_value() {
    let n = tank(json!({ "V": "1 L" }), json!({ "dead_volume": "= V" }), json!({ "p0": "= supply.p" }));
    let mut flat = load_with(&[("m.json", n)]).unwrap();
    graph::apply_set(&mut flat, "supply.p=7 bar").unwrap();
    graph::apply_set(&mut flat, "V=2 L").unwrap();
    let c = build(&flat).unwrap();
    assert!((si(&c, "tank.p0") - 7e5).abs() < 1e-9);
    assert!((si(&c, "tank.dead_volume") - 2e-3).abs() < 1e-15);
    // an expression on the command line is evaluated at the top level
    graph::apply_set(&mut flat, "tank.T0== supply.T - 20 K").unwrap();
    let c = build(&flat).unwrap();
    assert!((si(&c, "tank.T0") - 273.15).abs() < 1e-12);
}

#[test]
fn a_plain_number_for_a_parameter_keeps_its_dimension_and_warns() {
    let n = tank(json!({ "V": "1 L" }), json!({ "dead_volume": "= V" }), json!({}));
    let mut flat = load_with(&[("m.json", n)]).unwrap();
    graph::apply_set(&mut flat, "V=0.002").unwrap();
    let c = build(&flat).unwrap();
    assert!((si(&c, "tank.dead_volume") - 2e-3).abs() < 1e-15);
    let w: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("V = 0.002") && w.contains("m3") && w.contains("write \"0.002 L\"")), "{w:?}");
}

#[test]
fn a_plain_number_for_a_pressure_is_pascal_with_a_warning() {
    let n = tank(json!({}), json!({ "dead_volume": "1 L" }), json!({}));
    let mut flat = load_with(&[("m.json", n)]).unwrap();
    graph::apply_set(&mut flat, "supply.p=6").unwrap();
    let c = build(&flat).unwrap();
    assert_eq!(si(&c, "supply.p"), 6.0);
    let w: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("supply.p = 6 is taken as 6 Pa (SI)") && w.contains("\"6 bar\"")), "{w:?}");
    // and a supply of 6 Pa is below the atmosphere
    assert!(w.iter().any(|w| w.contains("below")), "{w:?}");
    // a plain number where the usual unit is SI (seconds, kelvin) gives no warning
    let n = tank(json!({}), json!({ "dead_volume": "1 L", "tau_thermal": 2 }), json!({ "T0": 300 }));
    let c = build(&load_with(&[("m.json", n)]).unwrap()).unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn a_dimension_mismatch_names_file_component_and_parameter() {
    let n = tank(json!({ "V": "1 L" }), json!({ "dead_volume": "= V + supply.p" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["m.json", "component \"tank\"", "parameter \"dead_volume\"", "pressure", "volume"]);
    let n = tank(json!({ "V": "1 L" }), json!({ "dead_volume": "= supply.p" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["m.json", "\"dead_volume\"", "is a pressure, but the parameter is a volume"]);
    // a bare number in an expression is dimensionless
    let n = tank(json!({}), json!({ "dead_volume": "= 0.001" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["\"dead_volume\"", "plain number"]);
}

#[test]
fn an_unknown_name_is_named_with_a_suggestion() {
    let n = tank(json!({ "V_port": "1 L" }), json!({ "dead_volume": "= 2 * V_prot" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["m.json", "\"tank\"", "\"dead_volume\"", "unknown name \"V_prot\""]);
    let n = tank(json!({}), json!({ "dead_volume": "1 L" }), json!({ "p0": "= suply.p" }));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["\"p0\"", "suply.p"]);
}

#[test]
fn a_cycle_of_references_is_named() {
    let n = tank(json!({ "a": "= b * 2", "b": "= c + 1 L", "c": "= a" }), json!({ "dead_volume": "= a" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["m.json", "cycle"]);
    for name in ["a", "b", "c"] {
        assert!(e.contains(&format!("{name} ->")) || e.contains(&format!("-> {name}")), "{name} missing from {e}");
    }
    // a value referring to itself
    let n = tank(json!({}), json!({ "dead_volume": "= tank.dead_volume" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["cycle", "tank.dead_volume -> tank.dead_volume"]);
}

#[test]
fn syntax_errors_division_by_zero_and_non_finite_results_are_one_line() {
    let cases = [
        ("= 2 * (1 L", "column"),
        ("= 1 L / (supply.p - 6 bar) * 1 Pa", "zero"),
        ("= 1 L * exp(1000)", "overflows"),
        ("= 2 ** 1 L", "column"),
    ];
    for (expr, word) in cases {
        let n = tank(json!({}), json!({ "dead_volume": expr }), json!({}));
        let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
        assert_names(&e, &["m.json", "\"tank\"", "\"dead_volume\"", word]);
    }
}

#[test]
fn control_characters_in_an_expression_are_escaped() {
    let n = tank(json!({}), json!({ "dead_volume": "= 1 L +\n\u{1b}[31m" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert!(!e.contains('\n') && !e.contains('\u{1b}'), "{e:?}");
}

#[test]
fn choices_cannot_be_used_as_numbers() {
    let n = tank(json!({}), json!({ "dead_volume": "1 L", "tau_thermal": "= tank.orientation * 1 s" }), json!({}));
    let e = build(&load_with(&[("m.json", n)]).unwrap()).unwrap_err();
    assert_names(&e, &["\"tau_thermal\"", "orientation", "choice"]);
}

#[test]
fn defaults_of_blocks_can_be_referred_to() {
    // T_wall is not written: its default (293.15 K) is used
    let n = tank(json!({}), json!({ "dead_volume": "1 L" }), json!({ "T0": "= tank.T_wall" }));
    let c = build(&load_with(&[("m.json", n)]).unwrap()).unwrap();
    assert_eq!(si(&c, "tank.T0"), 293.15);
}

#[test]
fn bad_parameter_names_and_ids_are_refused() {
    let n = tank(json!({ "2x": "1 L" }), json!({ "dead_volume": "1 L" }), json!({}));
    assert_names(&load_with(&[("m.json", n)]).unwrap_err(), &["m.json", "\"2x\""]);
    let n = tank(json!({ "pi": "1 L" }), json!({ "dead_volume": "1 L" }), json!({}));
    assert_names(&load_with(&[("m.json", n)]).unwrap_err(), &["\"pi\""]);
    let mut n = tank(json!({}), json!({ "dead_volume": "1 L" }), json!({}));
    n["components"][2]["id"] = json!("my.tank");
    assert_names(&load_with(&[("m.json", n)]).unwrap_err(), &["m.json", "\"my.tank\"", "'_' and '-'"]);
}

/// A cylinder subsystem written with parameters (new style) and one interface alias.
fn cylinder_lib() -> Json {
    json!({
        "parameters": {
            "bore": { "value": "45 mm", "description": "piston diameter" },
            "stroke": "450 mm",
            "V_dead": "20 cm3"
        },
        "components": [
            { "id": "head", "type": "chamber", "params": { "dead_volume": "= V_dead", "bore": "= bore", "orientation": "extend" } },
            { "id": "rod", "type": "chamber",
              "params": { "dead_volume": "= V_dead", "bore": "= bore", "rod_diameter": "15 mm", "orientation": "retract", "length_at_zero": "= stroke" } },
            { "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "= stroke" } }
        ],
        "connections": [["head.piston", "piston.rod"], ["rod.piston", "piston.rod"]],
        "interface": { "ports": { "A": "head.port", "B": "rod.port", "x": "piston.x" }, "params": { "T0": ["head.T0", "rod.T0"] } }
    })
}

fn parent(cyl_params: Json) -> Json {
    json!({
        "parameters": { "D": "32 mm", "T_amb": "300 K" },
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar", "T": "= T_amb" } },
            { "id": "exhaust", "type": "atmosphere" },
            { "id": "dcv", "type": "valve_5_2", "params": { "C": "200 L/min/bar", "b": 0.3 } },
            { "id": "cyl", "type": "subsystem", "file": "lib/cyl.json", "params": cyl_params },
            { "id": "controller", "type": "cycler", "params": { "stroke": "= cyl.stroke" } }
        ],
        "connections": [
            ["supply.port", "dcv.P"], ["dcv.A", "cyl.A"], ["dcv.B", "cyl.B"],
            ["dcv.EA", "exhaust.port"], ["dcv.EB", "exhaust.port"],
            { "from": "cyl.x", "to": "controller.x" }, { "from": "controller.command", "to": "dcv.command" }
        ]
    })
}

#[test]
fn subsystems_take_parameters_from_their_instance_in_the_instance_scope() {
    let flat = load_with(&[("m.json", parent(json!({ "bore": "= D", "T0": "= T_amb" }))), ("lib/cyl.json", cylinder_lib())]).unwrap();
    let c = build(&flat).unwrap();
    // "= D" is evaluated where it was written (the parent), "= bore" inside the cylinder
    assert!((si(&c, "cyl.bore") - 0.032).abs() < 1e-15);
    assert!((si(&c, "cyl.head.bore") - 0.032).abs() < 1e-15);
    assert!((si(&c, "cyl.rod.bore") - 0.032).abs() < 1e-15);
    assert!((si(&c, "cyl.rod.length_at_zero") - 0.45).abs() < 1e-15);
    assert!((si(&c, "controller.stroke") - 0.45).abs() < 1e-15);
    assert_eq!(si(&c, "cyl.head.T0"), 300.0);
    assert_eq!(si(&c, "cyl.rod.T0"), 300.0);
    // the cylinder's own default where the instance says nothing
    assert!((si(&c, "cyl.head.dead_volume") - 20e-6).abs() < 1e-18);
}

#[test]
fn subsystem_parameters_are_reachable_from_set() {
    let mut flat = load_with(&[("m.json", parent(json!({}))), ("lib/cyl.json", cylinder_lib())]).unwrap();
    graph::apply_set(&mut flat, "cyl.stroke=300 mm").unwrap();
    graph::apply_set(&mut flat, "cyl.T0=310 K").unwrap();
    graph::apply_set(&mut flat, "T_amb=280 K").unwrap();
    let c = build(&flat).unwrap();
    assert!((si(&c, "cyl.piston.stroke") - 0.3).abs() < 1e-15);
    assert!((si(&c, "controller.stroke") - 0.3).abs() < 1e-15, "the controller follows the cylinder");
    assert_eq!(si(&c, "cyl.head.T0"), 310.0);
    assert_eq!(si(&c, "supply.T"), 280.0);
    // unknown names say what the subsystem has
    let e = graph::apply_set(&mut flat, "cyl.diameter=40 mm").unwrap_err().to_string();
    assert_names(&e, &["cyl.diameter", "\"cyl\"", "bore", "stroke"]);
}

#[test]
fn geometry_that_disagrees_between_blocks_is_a_warning() {
    // cycler stroke written by hand, beyond the piston's stroke
    let mut n = parent(json!({}));
    n["components"][4]["params"]["stroke"] = json!("500 mm");
    let flat = load_with(&[("m.json", n), ("lib/cyl.json", cylinder_lib())]).unwrap();
    let c = build(&flat).unwrap();
    let w: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("controller.stroke") && w.contains("never reached")), "{w:?}");
    // piston stroke against the rod chamber's gas column
    let mut flat = load_with(&[("m.json", parent(json!({}))), ("lib/cyl.json", cylinder_lib())]).unwrap();
    graph::apply_set(&mut flat, "cyl.piston.stroke=300 mm").unwrap();
    let c = build(&flat).unwrap();
    let w: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("cyl.rod.length_at_zero = 450 mm") && w.contains("cyl.piston.stroke = 300 mm")), "{w:?}");
    // and a consistent circuit has none
    let flat = load_with(&[("m.json", parent(json!({}))), ("lib/cyl.json", cylinder_lib())]).unwrap();
    assert!(build(&flat).unwrap().warnings.is_empty());
}

#[test]
fn a_written_value_is_kept_as_written_in_the_flat_netlist() {
    // expressions stay text in the flat netlist; only the build replaces them
    let n = tank(json!({}), json!({ "dead_volume": "1 L" }), json!({ "p0": "= supply.p" }));
    let flat = load_with(&[("m.json", n)]).unwrap();
    assert_eq!(flat.component("tank").unwrap().init.get("p0"), Some(&Value::Text("= supply.p".into())));
    let (concrete, _) = graph::params::concrete(&flat).unwrap();
    assert_eq!(concrete.component("tank").unwrap().init.get("p0"), Some(&Value::Number(6e5)));
}
