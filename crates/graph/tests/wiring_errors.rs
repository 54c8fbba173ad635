//! Wiring errors: one test per class of mistake a netlist can contain, each
//! checking that the message names what is at fault (file position,
//! component id, parameter, port), plus one working subsystem.
//!
//! The pipeline under test is the one the command line runs:
//! text → `graph::expand::parse` / `graph::load` (JSON errors with line and
//! column, subsystem expansion through a [`graph::Loader`]) → `graph::apply_set`
//! (`--set ID.PARAM=VALUE`) → `graph::build` (blocks, ports, domains, and
//! causality: one effort per pneumatic node, one inertia per mechanical node).
//! Files live in memory ([`MemLoader`]); no file system is touched.

use graph::{FlatNetlist, GraphError, Loader};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Netlist files in memory, keyed by path.
#[derive(Debug, Default)]
struct MemLoader(HashMap<PathBuf, String>);

impl MemLoader {
    fn with(files: &[(&str, String)]) -> Self {
        MemLoader(files.iter().map(|(p, t)| (PathBuf::from(p), t.clone())).collect())
    }
}

impl Loader for MemLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        self.0.get(path).cloned().ok_or_else(|| format!("no such file {}", path.display()))
    }
}

/// Parse and expand an inline netlist (no files); errors as their messages.
fn flatten(netlist: &Value) -> Result<FlatNetlist, String> {
    let parsed = graph::expand::parse(&netlist.to_string(), "inline.json").map_err(|e| e.to_string())?;
    graph::expand::flatten(&MemLoader::default(), &parsed, Path::new(""), 0).map_err(|e| e.to_string())
}

/// The message of the error that parsing, expanding or building `netlist` gives.
fn error_of(netlist: Value) -> String {
    match flatten(&netlist).and_then(|flat| graph::build(&flat).map_err(|e| e.to_string())) {
        Ok(_) => panic!("expected an error for {netlist:#}"),
        Err(e) => e,
    }
}

fn assert_names(message: &str, needles: &[&str]) {
    for n in needles {
        assert!(message.contains(n), "message does not name {n:?}: {message}");
    }
}

/// A supply filling a tank through a restriction: valid, the base of the mutations below.
fn tank_fill(tank_params: Value) -> Value {
    json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
            { "id": "valve", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "tank", "type": "chamber", "params": tank_params }
        ],
        "connections": [["supply.port", "valve.a"], ["valve.b", "tank.port"]]
    })
}

/// A cylinder driven by one chamber, with its moving mass and friction: valid.
fn cylinder_components() -> Vec<Value> {
    vec![
        json!({ "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } }),
        json!({ "id": "valve", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } }),
        json!({ "id": "head", "type": "chamber", "params": { "dead_volume": "20 cm3", "bore": "32 mm" } }),
        json!({ "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "100 mm" } }),
        json!({ "id": "friction", "type": "friction", "params": { "k0": "10 N" } }),
    ]
}

fn cylinder_connections() -> Vec<Value> {
    vec![
        json!(["supply.port", "valve.a"]),
        json!(["valve.b", "head.port"]),
        json!(["head.piston", "piston.rod"]),
        json!(["friction.rod", "piston.rod"]),
        json!({ "from": "head.p", "to": "friction.p1" }),
        json!({ "from": "head.p", "to": "friction.p2" }),
    ]
}

fn cylinder(components: Vec<Value>, connections: Vec<Value>) -> Value {
    json!({ "components": components, "connections": connections })
}

#[test]
fn the_base_netlists_build() {
    let c = graph::build(&flatten(&tank_fill(json!({ "dead_volume": "1 L" }))).unwrap()).unwrap();
    assert_eq!(c.instances.len(), 3);
    assert_eq!(c.pneumatic_nodes.len(), 2);
    let c = graph::build(&flatten(&cylinder(cylinder_components(), cylinder_connections())).unwrap()).unwrap();
    assert_eq!(c.mechanical_nodes.len(), 1);
    assert_eq!(c.mechanical_nodes[0].ports.len(), 3);
}

#[test]
fn malformed_json_gives_file_line_and_column() {
    // missing comma after "a" on line 3; the offending '"' of "type" is column 17
    let text = "{\n  \"components\": [\n    { \"id\": \"a\" \"type\": \"chamber\" }\n  ]\n}\n";
    let loader = MemLoader::with(&[("circuits/bad.json", text.to_string())]);
    let e = graph::load(&loader, Path::new("circuits/bad.json")).unwrap_err();
    match &e {
        GraphError::Json { file, line, column, .. } => {
            assert_eq!(file, "circuits/bad.json");
            assert_eq!((*line, *column), (3, 17));
        }
        other => panic!("expected a JSON error, got {other}"),
    }
    assert!(e.to_string().starts_with("circuits/bad.json:3:17: "), "{e}");
    // the message keeps serde's reason but not its duplicated "at line" tail
    assert!(!e.to_string().contains("at line"), "{e}");
}

#[test]
fn json_of_the_wrong_shape_is_located_too() {
    // a connection that is neither a pair nor {from, to}, on line 4
    let text = "{\n  \"components\": [],\n  \"connections\": [\n    [\"a.x\", \"b.y\", \"c.z\"]\n  ]\n}";
    // serde reports an untagged-enum mismatch where it finished buffering:
    // line 4 (the entry) or line 5 (the end of the list holding it)
    let e = graph::expand::parse(text, "shape.json").unwrap_err();
    assert!(matches!(e, GraphError::Json { ref file, line: 4..=5, .. } if file == "shape.json"), "{e}");
    assert_names(&e.to_string(), &["Connection"]);
}

#[test]
fn unknown_component_type_is_named_with_its_id() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][2]["type"] = json!("chamberr");
    let e = error_of(n);
    assert_names(&e, &["\"tank\"", "\"chamberr\"", "chamber, ", "conductance, "]);
}

#[test]
fn unknown_parameter_is_named_with_the_accepted_ones() {
    let e = error_of(tank_fill(json!({ "dead_volume": "1 L", "volume": "1 L" })));
    assert_names(&e, &["\"tank\"", "\"volume\"", "accepted", "dead_volume"]);
}

#[test]
fn unknown_initial_condition_is_an_unknown_parameter_too() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][2]["init"] = json!({ "p_0": "2 bar" });
    assert_names(&error_of(n), &["\"tank\"", "\"p_0\""]);
}

#[test]
fn wrong_unit_names_the_parameter_and_the_value() {
    let e = error_of(tank_fill(json!({ "dead_volume": "1 bar" })));
    assert_names(&e, &["\"tank\"", "\"dead_volume\"", "1 bar"]);
}

#[test]
fn missing_required_parameter_is_named() {
    let e = error_of(tank_fill(json!({})));
    assert_names(&e, &["\"tank\"", "missing", "\"dead_volume\""]);
}

#[test]
fn values_out_of_range_are_named_with_the_range() {
    // critical pressure ratio outside (0, 1)
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][1]["params"]["b"] = json!(1.2);
    assert_names(&error_of(n), &["\"valve\"", "\"b\"", "1.2", "(0, 1)"]);
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][1]["params"]["b"] = json!(0.0);
    assert_names(&error_of(n), &["\"valve\"", "\"b\"", "(0, 1)"]);
    // sonic conductance not > 0
    for c in [json!(0.0), json!("-2 L/min/bar")] {
        let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
        n["components"][1]["params"]["C"] = c;
        assert_names(&error_of(n), &["\"valve\"", "\"C\"", "> 0"]);
    }
    // negative volume
    let e = error_of(tank_fill(json!({ "dead_volume": "-1 cm3" })));
    assert_names(&e, &["\"tank\"", "\"dead_volume\"", ">= 0"]);
    // a rigid tank with no volume at all
    let e = error_of(tank_fill(json!({ "dead_volume": 0.0 })));
    assert_names(&e, &["\"tank\"", "\"dead_volume\""]);
}

#[test]
fn duplicated_id_is_named() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][1]["id"] = json!("supply");
    let e = error_of(n);
    assert_names(&e, &["\"supply\"", "twice"]);
}

#[test]
fn bad_id_is_named() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["components"][2]["id"] = json!("my tank");
    assert_names(&error_of(n), &["\"my tank\""]);
}

#[test]
fn unknown_port_is_named_with_the_ports_that_exist() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["connections"][1] = json!(["valve.b", "tank.prt"]);
    let e = error_of(n);
    assert_names(&e, &["\"tank.prt\"", "port, p, T"]);
}

#[test]
fn connection_to_a_missing_component_is_named() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["connections"][1] = json!(["valve.b", "tnak.port"]);
    assert_names(&error_of(n), &["\"tnak.port\"", "\"tnak\""]);
}

#[test]
fn unconnected_port_is_named_with_its_doc() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["connections"] = json!([["supply.port", "valve.a"]]);
    let e = error_of(n);
    // valve.b comes before tank.port in component order
    assert_names(&e, &["\"valve.b\"", "not connected", "side b"]);
}

#[test]
fn unconnected_signal_input_is_named() {
    let mut conns = cylinder_connections();
    conns.pop(); // friction.p2 left open
    let e = error_of(cylinder(cylinder_components(), conns));
    assert_names(&e, &["\"friction.p2\"", "not connected", "rod-side pressure"]);
}

#[test]
fn signal_input_driven_twice_is_named() {
    let mut conns = cylinder_connections();
    conns.push(json!({ "from": "piston.x", "to": "friction.p2" }));
    assert_names(&error_of(cylinder(cylinder_components(), conns)), &["\"friction.p2\"", "more than one"]);
}

#[test]
fn pneumatic_to_mechanical_connection_names_both_domains() {
    let mut conns = cylinder_connections();
    conns[1] = json!(["valve.b", "piston.rod"]);
    let e = error_of(cylinder(cylinder_components(), conns));
    assert_names(&e, &["\"valve.b\" (pneumatic)", "\"piston.rod\" (mechanical)", "different domains"]);
}

#[test]
fn signal_to_power_port_is_a_domain_error() {
    let mut conns = cylinder_connections();
    conns[4] = json!({ "from": "head.p", "to": "valve.b" });
    let e = error_of(cylinder(cylinder_components(), conns));
    assert_names(&e, &["\"head.p\" (signal)", "\"valve.b\" (pneumatic)"]);
}

#[test]
fn signal_output_to_output_is_refused() {
    let mut conns = cylinder_connections();
    conns.push(json!({ "from": "head.p", "to": "piston.x" }));
    let e = error_of(cylinder(cylinder_components(), conns));
    assert_names(&e, &["\"head.p\"", "\"piston.x\"", "one output to one input"]);
}

#[test]
fn port_connected_to_itself_is_refused() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["connections"] = json!([["supply.port", "valve.a"], ["valve.b", "tank.port"], ["tank.port", "tank.port"]]);
    assert_names(&error_of(n), &["\"tank.port\"", "itself"]);
}

#[test]
fn two_chambers_joined_directly_need_derivative_causality() {
    let n = json!({
        "components": [
            { "id": "left", "type": "chamber", "params": { "dead_volume": "1 L" } },
            { "id": "right", "type": "chamber", "params": { "dead_volume": "2 L" } }
        ],
        "connections": [["left.port", "right.port"]]
    });
    let e = error_of(n);
    assert_names(&e, &["left.port", "right.port", "derivative causality", "conductance"]);
}

#[test]
fn chamber_tied_to_a_pressure_source_is_derivative_causality_too() {
    let mut n = tank_fill(json!({ "dead_volume": "1 L" }));
    n["connections"] = json!([["supply.port", "valve.a"], ["valve.b", "tank.port"], ["supply.port", "tank.port"]]);
    assert_names(&error_of(n), &["supply.port", "tank.port", "derivative causality"]);
}

#[test]
fn junction_cluster_without_capacity_or_source_is_floating() {
    // two restrictions and a flow source, no chamber or pressure source anywhere
    let n = json!({
        "components": [
            { "id": "pump", "type": "mass_flow_source", "params": { "mdot": "1 g/s" } },
            { "id": "r1", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "r2", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } }
        ],
        "connections": [["pump.port", "r1.a"], ["r1.b", "r2.a"], ["r2.b", "r1.a"]]
    });
    let e = error_of(n);
    assert_names(&e, &["pump.port", "r1.a", "r1.b", "r2.a", "neither a capacity nor a source"]);
}

#[test]
fn junction_next_to_a_source_is_not_floating() {
    // the same junction between two restrictions, now bordering a supply and a tank
    let n = json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
            { "id": "r1", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "r2", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "tank", "type": "chamber", "params": { "dead_volume": "1 L" } }
        ],
        "connections": [["supply.port", "r1.a"], ["r1.b", "r2.a"], ["r2.b", "tank.port"]]
    });
    let c = graph::build(&flatten(&n).unwrap()).unwrap();
    assert_eq!(c.junction_clusters.len(), 1);
    assert_eq!(c.junction_clusters[0].len(), 1);
}

#[test]
fn mechanical_node_without_mass_is_named() {
    let comps: Vec<Value> = cylinder_components().into_iter().filter(|c| c["id"] != "piston").collect();
    let conns = vec![
        json!(["supply.port", "valve.a"]),
        json!(["valve.b", "head.port"]),
        json!(["head.piston", "friction.rod"]),
        json!({ "from": "head.p", "to": "friction.p1" }),
        json!({ "from": "head.p", "to": "friction.p2" }),
    ];
    let e = error_of(cylinder(comps, conns));
    assert_names(&e, &["head.piston", "friction.rod", "no moving mass"]);
}

#[test]
fn two_pistons_tied_are_named() {
    let mut comps = cylinder_components();
    comps.push(json!({ "id": "load", "type": "piston", "params": { "mass": "5 kg", "stroke": "100 mm" } }));
    let mut conns = cylinder_connections();
    conns.push(json!(["load.rod", "piston.rod"]));
    let e = error_of(cylinder(comps, conns));
    assert_names(&e, &["piston.rod", "load.rod", "merge them into one piston"]);
}

#[test]
fn set_with_unknown_component_is_named() {
    let mut flat = flatten(&tank_fill(json!({ "dead_volume": "1 L" }))).unwrap();
    let e = graph::apply_set(&mut flat, "vlave.C=2 L/min/bar").unwrap_err().to_string();
    assert_names(&e, &["vlave.C=2 L/min/bar", "no component \"vlave\""]);
    let e = graph::apply_set(&mut flat, "valve.C").unwrap_err().to_string();
    assert_names(&e, &["valve.C", "NAME=VALUE"]);
    let e = graph::apply_set(&mut flat, "simulation.tolerance=1e-3").unwrap_err().to_string();
    assert_names(&e, &["\"tolerance\"", "rtol"]);
}

#[test]
fn set_reaches_the_block_and_its_errors_name_the_parameter() {
    let mut flat = flatten(&tank_fill(json!({ "dead_volume": "1 L" }))).unwrap();
    graph::apply_set(&mut flat, "valve.b=1.5").unwrap();
    let e = graph::build(&flat).unwrap_err().to_string();
    assert_names(&e, &["\"valve\"", "\"b\"", "(0, 1)"]);
    // an unknown parameter through --set is refused where it is set (so that
    // Python's Model.set raises at once), with the nearest name
    let mut flat = flatten(&tank_fill(json!({ "dead_volume": "1 L" }))).unwrap();
    let e = graph::apply_set(&mut flat, "tank.volume=2 L").unwrap_err().to_string();
    assert_names(&e, &["\"tank\"", "\"volume\"", "accepted: ", "dead_volume"]);
    let e = graph::apply_set(&mut flat, "valve.CC=2 L/min/bar").unwrap_err().to_string();
    assert_names(&e, &["\"valve\"", "\"CC\"", "did you mean \"C\""]);
    let e = graph::apply_set(&mut flat, "valv.C=2 L/min/bar").unwrap_err().to_string();
    assert_names(&e, &["did you mean \"valve\""]);
    graph::apply_set(&mut flat, "tank.p0=3 bar").expect("an initial value is a parameter too");
}

// ---------------------------------------------------------------------------
// Subsystems
// ---------------------------------------------------------------------------

/// A double-acting cylinder as a reusable subsystem: two chambers, the
/// moving mass and its friction; ports A, B, x exposed; bore and stroke
/// exposed as parameters that set several inner parameters at once.
fn cylinder_subsystem() -> String {
    json!({
        "name": "cylinder",
        "components": [
            { "id": "head", "type": "chamber", "params": { "dead_volume": "20 cm3", "bore": "32 mm", "orientation": "extend" } },
            { "id": "rod", "type": "chamber",
              "params": { "dead_volume": "20 cm3", "bore": "32 mm", "rod_diameter": "12 mm", "orientation": "retract", "length_at_zero": "100 mm" } },
            { "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "100 mm" } },
            { "id": "friction", "type": "friction", "params": { "k0": "10 N" } }
        ],
        "connections": [
            ["head.piston", "piston.rod"], ["rod.piston", "piston.rod"], ["friction.rod", "piston.rod"],
            { "from": "head.p", "to": "friction.p1" }, { "from": "rod.p", "to": "friction.p2" }
        ],
        "interface": {
            "ports": { "A": "head.port", "B": "rod.port", "x": "piston.x" },
            "params": { "bore": ["head.bore", "rod.bore"], "stroke": ["piston.stroke", "rod.length_at_zero"] }
        }
    })
    .to_string()
}

fn parent(cyl_params: Value) -> String {
    json!({
        "name": "parent",
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
            { "id": "exhaust", "type": "atmosphere" },
            { "id": "dcv", "type": "valve_5_2", "params": { "C": "200 L/min/bar", "b": 0.3 } },
            { "id": "cyl", "type": "subsystem", "file": "parts/cylinder.json", "params": cyl_params },
            { "id": "controller", "type": "cycler", "params": { "stroke": "200 mm" } }
        ],
        "connections": [
            ["supply.port", "dcv.P"], ["dcv.A", "cyl.A"], ["dcv.B", "cyl.B"],
            ["dcv.EA", "exhaust.port"], ["dcv.EB", "exhaust.port"],
            { "from": "cyl.x", "to": "controller.x" }, { "from": "controller.command", "to": "dcv.command" }
        ]
    })
    .to_string()
}

fn loader_with_parent(cyl_params: Value) -> MemLoader {
    MemLoader::with(&[("lib/parent.json", parent(cyl_params)), ("lib/parts/cylinder.json", cylinder_subsystem())])
}

#[test]
fn subsystem_expands_with_prefixed_ids_ports_and_parameters() {
    let loader = loader_with_parent(json!({ "bore": "40 mm", "stroke": "200 mm" }));
    let flat = graph::load(&loader, Path::new("lib/parent.json")).unwrap();
    let ids: Vec<&str> = flat.components.iter().map(|c| c.id.as_str()).collect();
    for id in ["cyl.head", "cyl.rod", "cyl.piston", "cyl.friction", "supply", "dcv", "controller"] {
        assert!(ids.contains(&id), "{id} missing from {ids:?}");
    }
    assert!(!ids.contains(&"cyl"), "the subsystem itself stays in the flat list: {ids:?}");
    // exposed ports are rewritten to the inner ports, inner connections are prefixed
    let has = |a: &str, b: &str| flat.connections.iter().any(|(x, y)| x == a && y == b);
    assert!(has("dcv.A", "cyl.head.port") && has("dcv.B", "cyl.rod.port"), "{:?}", flat.connections);
    assert!(has("cyl.piston.x", "controller.x"), "{:?}", flat.connections);
    assert!(has("cyl.head.piston", "cyl.piston.rod"), "{:?}", flat.connections);
    // an exposed parameter sets every inner target
    let param = |id: &str, p: &str| flat.components.iter().find(|c| c.id == id).and_then(|c| c.params.get(p)).cloned();
    let forty = graph::netlist::Value::Text("40 mm".into());
    let stroke = graph::netlist::Value::Text("200 mm".into());
    assert_eq!(param("cyl.head", "bore"), Some(forty.clone()));
    assert_eq!(param("cyl.rod", "bore"), Some(forty));
    assert_eq!(param("cyl.piston", "stroke"), Some(stroke.clone()));
    assert_eq!(param("cyl.rod", "length_at_zero"), Some(stroke));
    // and the whole thing builds, with one mechanical node inside the cylinder
    let circuit = graph::build(&flat).unwrap();
    let head = circuit.find("cyl.head").expect("cyl.head in the circuit");
    assert!(circuit.find("cyl.piston").is_some());
    assert_eq!(circuit.mechanical_nodes.len(), 1);
    assert_eq!(circuit.port_name(circuit.mechanical_nodes[0].inertia), "cyl.piston.rod");
    // the head chamber is wired to the valve's A port
    let head_node = circuit.instances[head].port_nodes[0].expect("head.port has a node");
    let dcv = circuit.find("dcv").unwrap();
    let a = circuit.instances[dcv].block.ports().iter().position(|p| p.name == "A").unwrap();
    assert_eq!(circuit.instances[dcv].port_nodes[a], Some(head_node));
}

#[test]
fn set_reaches_components_inside_a_subsystem() {
    let loader = loader_with_parent(json!({}));
    let mut flat = graph::load(&loader, Path::new("lib/parent.json")).unwrap();
    graph::apply_set(&mut flat, "cyl.piston.mass=3 kg").unwrap();
    let piston = flat.components.iter().find(|c| c.id == "cyl.piston").unwrap();
    assert_eq!(piston.params.get("mass"), Some(&graph::netlist::Value::Text("3 kg".into())));
    graph::build(&flat).unwrap();
}

#[test]
fn subsystem_with_unknown_exposed_parameter_lists_what_it_exposes() {
    let loader = loader_with_parent(json!({ "diameter": "40 mm" }));
    let e = graph::load(&loader, Path::new("lib/parent.json")).unwrap_err().to_string();
    assert_names(&e, &["component \"cyl\"", "\"diameter\"", "bore, stroke"]);
}

#[test]
fn missing_subsystem_file_is_named_with_its_resolved_path() {
    let loader = MemLoader::with(&[("lib/parent.json", parent(json!({})))]);
    let e = graph::load(&loader, Path::new("lib/parent.json")).unwrap_err().to_string();
    assert_names(&e, &["lib/parts/cylinder.json"]);
}

#[test]
fn malformed_subsystem_file_is_located_in_that_file() {
    let broken = cylinder_subsystem().replacen("\"head\"", "\"head\",,", 1);
    let loader = MemLoader::with(&[("lib/parent.json", parent(json!({}))), ("lib/parts/cylinder.json", broken)]);
    let e = graph::load(&loader, Path::new("lib/parent.json")).unwrap_err();
    assert!(matches!(e, GraphError::Json { ref file, line: 1, .. } if file == "lib/parts/cylinder.json"), "{e}");
}

#[test]
fn subsystem_including_itself_is_stopped() {
    let me = json!({
        "components": [{ "id": "again", "type": "subsystem", "file": "loop.json" }],
        "connections": []
    })
    .to_string();
    let loader = MemLoader::with(&[("loop.json", me)]);
    let e = graph::load(&loader, Path::new("loop.json")).unwrap_err().to_string();
    // the message names the chain of files, not just a depth
    assert_names(&e, &["includes itself", "loop.json -> loop.json"]);
}

#[test]
fn subsystems_nested_too_deep_are_stopped_with_the_chain_of_files() {
    // level k includes level k + 1; 20 distinct files, none including itself
    let files: Vec<(String, String)> = (0..20)
        .map(|k| {
            let text = json!({
                "components": [{ "id": "inner", "type": "subsystem", "file": format!("level{}.json", k + 1) }],
                "connections": []
            })
            .to_string();
            (format!("level{k}.json"), text)
        })
        .collect();
    let refs: Vec<(&str, String)> = files.iter().map(|(n, t)| (n.as_str(), t.clone())).collect();
    let loader = MemLoader::with(&refs);
    let e = graph::load(&loader, Path::new("level0.json")).unwrap_err().to_string();
    assert_names(&e, &["nested more than 16 deep", "level0.json -> level1.json", "level17.json"]);
}

// ---------------------------------------------------------------------------
// A double-acting cylinder wired from raw chambers (issue 28's two mistakes)
// ---------------------------------------------------------------------------

/// A 5/2 valve driving a double-acting cylinder built from two chambers, a
/// piston and friction, reversed by a cycler: valid as written; `rod` sets
/// the rod chamber's parameters.
fn raw_double_acting(rod: Value) -> Value {
    json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
            { "id": "exhaust", "type": "atmosphere" },
            { "id": "dcv", "type": "valve_5_2", "params": { "C": "100 L/min/bar", "b": 0.3 } },
            { "id": "head", "type": "chamber", "params": { "dead_volume": "20 cm3", "bore": "45 mm", "orientation": "extend" } },
            { "id": "rod", "type": "chamber", "params": rod },
            { "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "450 mm", "rod_diameter": "15 mm" } },
            { "id": "friction", "type": "friction", "params": { "k0": "10 N" } },
            { "id": "controller", "type": "cycler", "params": { "stroke": "450 mm" } }
        ],
        "connections": [
            ["supply.port", "dcv.P"], ["dcv.A", "head.port"], ["dcv.B", "rod.port"],
            ["dcv.EA", "exhaust.port"], ["dcv.EB", "exhaust.port"],
            ["head.piston", "piston.rod"], ["rod.piston", "piston.rod"], ["friction.rod", "piston.rod"],
            { "from": "head.p", "to": "friction.p1" }, { "from": "rod.p", "to": "friction.p2" },
            { "from": "piston.x", "to": "controller.x" }, { "from": "controller.command", "to": "dcv.command" }
        ]
    })
}

fn rod_params(drop: &str) -> Value {
    let mut p =
        json!({ "dead_volume": "20 cm3", "bore": "45 mm", "rod_diameter": "15 mm", "orientation": "retract", "length_at_zero": "450 mm" });
    p.as_object_mut().unwrap().remove(drop);
    p
}

/// The error `graph::load` + `graph::build` give for `netlist` written in `circuits/m.json`.
fn error_in_file(netlist: &Value) -> String {
    let loader = MemLoader::with(&[("circuits/m.json", netlist.to_string())]);
    let flat = graph::expand::load(&loader, Path::new("circuits/m.json")).unwrap();
    match graph::build(&flat) {
        Ok(c) => panic!("expected an error, built with warnings {:?}", c.warnings),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_raw_double_acting_cylinder_wired_right_builds_without_warnings() {
    let c = graph::build(&flatten(&raw_double_acting(rod_params("none"))).unwrap()).unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn a_rod_chamber_without_a_gas_column_is_one_error_naming_the_chamber_and_the_fix() {
    // before: `check` passed and the integrator failed with "step size fell below ... rod.T"
    let e = error_in_file(&raw_double_acting(rod_params("length_at_zero")));
    assert!(e.starts_with("circuits/m.json: component \"rod\", parameter \"length_at_zero\": "), "{e}");
    assert_names(&e, &["piston.stroke = 450 mm", "no gas column", "x = 14.1 mm", "set \"length_at_zero\" to the stroke"]);
    assert_eq!(e.lines().count(), 1, "{e}");
    // a gas column shorter than the stroke empties the chamber too: x = 100 mm + 20 cm3 / 1414 mm2 (45 mm bore, 15 mm rod) = 114.1 mm
    let mut short = rod_params("none");
    short["length_at_zero"] = json!("100 mm");
    let e = error_in_file(&raw_double_acting(short));
    assert_names(&e, &["\"rod\"", "length_at_zero", "a gas column of 100 mm", "x = 114.1 mm"]);
    // a column longer than the stroke runs (the chamber never empties): a warning naming both parameters
    let mut long = rod_params("none");
    long["length_at_zero"] = json!("500 mm");
    let c = graph::build(&flatten(&raw_double_acting(long)).unwrap()).unwrap();
    let w: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("rod.length_at_zero = 500 mm but piston.stroke = 450 mm")), "{w:?}");
}

#[test]
fn a_rod_chamber_left_at_orientation_extend_is_one_error_naming_the_chamber_and_the_fix() {
    // before: `check` passed and the piston stalled at the upper stop for the whole run
    let e = error_in_file(&raw_double_acting(rod_params("orientation")));
    assert!(e.starts_with("circuits/m.json: component \"rod\", parameter \"orientation\": "), "{e}");
    assert_names(&e, &["head and rod both push the piston toward extend", "\"orientation\": \"retract\""]);
    assert_eq!(e.lines().count(), 1, "{e}");
    // the head chamber turned the wrong way is named instead
    let mut n = raw_double_acting(rod_params("none"));
    n["components"][3]["params"]["orientation"] = json!("retract");
    let e = error_in_file(&n);
    assert!(e.contains("component \"head\", parameter \"orientation\"") && e.contains("\"orientation\": \"extend\""), "{e}");
}
