//! The model interface section (`interface.inputs` / `interface.outputs`):
//! how inputs bind to signal ports and live parameters in a standalone and
//! an externally driven build, how outputs bind to recorded values, units
//! and start values, and one test per mistake, each checking that the
//! message names the file, the input or output and what is wrong.
//!
//! The circuit is the paper's meter-out rig written inline (a cycler drives
//! the 5/2 valve), so that no file is read.

use graph::interface::{Binding, Drive, OutputSource};
use graph::{Circuit, FlatNetlist, Loader};
use serde_json::{json, Value};
use std::path::Path;

/// Meter-out: supply, 5/2 valve, two chambers, piston, friction, cycler.
fn meter_out(interface: Value) -> Value {
    json!({
        "name": "rig",
        "parameters": { "p_supply": "4 bar", "stroke": "450 mm" },
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "= p_supply", "T": "292 K" } },
            { "id": "exhaust", "type": "atmosphere", "params": { "p": "0.98 bar" } },
            { "id": "dcv", "type": "valve_5_2", "params": { "C": "490 L/min/bar", "b": 0.3 } },
            { "id": "head", "type": "chamber", "params": { "dead_volume": "20 cm3", "bore": "45 mm", "orientation": "extend" } },
            { "id": "rod", "type": "chamber",
              "params": { "dead_volume": "20 cm3", "bore": "45 mm", "rod_diameter": "15 mm", "orientation": "retract", "length_at_zero": "= stroke" } },
            { "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "= stroke", "rod_diameter": "15 mm" } },
            { "id": "friction", "type": "friction", "params": { "k0": "10 N" } },
            { "id": "controller", "type": "cycler", "params": { "stroke": "= stroke" } }
        ],
        "connections": [
            ["supply.port", "dcv.P"], ["dcv.A", "head.port"], ["dcv.B", "rod.port"],
            ["dcv.EA", "exhaust.port"], ["dcv.EB", "exhaust.port"],
            ["head.piston", "piston.rod"], ["rod.piston", "piston.rod"], ["friction.rod", "piston.rod"],
            { "from": "head.p", "to": "friction.p1" }, { "from": "rod.p", "to": "friction.p2" },
            { "from": "piston.x", "to": "controller.x" },
            { "from": "controller.command", "to": "dcv.command" }
        ],
        "interface": interface
    })
}

/// One file, `rig.json`, in memory.
struct Rig(String);
impl Loader for Rig {
    fn read(&self, path: &Path) -> Result<String, String> {
        if path == Path::new("rig.json") {
            Ok(self.0.clone())
        } else {
            Err(format!("no file {}", path.display()))
        }
    }
}

fn flatten(netlist: &Value) -> Result<FlatNetlist, String> {
    graph::load(&Rig(netlist.to_string()), Path::new("rig.json")).map_err(|e| e.to_string())
}

fn build(netlist: &Value, drive: Drive) -> Result<Circuit, String> {
    graph::build_with(&flatten(netlist)?, drive).map_err(|e| e.to_string())
}

fn error_of(netlist: Value) -> String {
    match build(&netlist, Drive::External) {
        Ok(_) => panic!("expected an error for the interface {:#}", netlist["interface"]),
        Err(e) => e,
    }
}

fn assert_names(message: &str, needles: &[&str]) {
    for n in needles {
        assert!(message.contains(n), "message does not name {n:?}: {message}");
    }
}

/// The id of the block that drives signal input `port` ("dcv.command").
fn source_of(c: &Circuit, port: &str) -> String {
    let (id, name) = port.split_once('.').unwrap();
    let inst = &c.instances[c.find(id).unwrap()];
    let k = inst.block.ports().iter().filter(|p| p.kind == blocks::block::PortKind::SignalIn).position(|p| p.name == name).unwrap();
    c.port_name(inst.signal_sources[k])
}

fn valve_input() -> Value {
    json!({ "inputs": { "valve": { "port": "dcv.command", "unit": "1", "start": 0, "description": "5/2 solenoid: 1 = extend" } } })
}

#[test]
fn a_port_input_replaces_the_connection_only_when_driven_from_outside() {
    let n = meter_out(valve_input());
    let alone = build(&n, Drive::Standalone).unwrap();
    assert_eq!(source_of(&alone, "dcv.command"), "controller.command");
    assert!(alone.find("input.valve").is_none(), "no source block when the netlist drives every bound port");
    let input = alone.interface.input("valve").unwrap();
    assert_eq!(input.live, None);
    assert_eq!(input.binding, Binding::Ports(vec!["dcv.command".into()]));
    assert_eq!(input.description.as_deref(), Some("5/2 solenoid: 1 = extend"));

    let driven = build(&n, Drive::External).unwrap();
    assert_eq!(source_of(&driven, "dcv.command"), "input.valve.value");
    let input = driven.interface.input("valve").unwrap();
    let live = input.live.as_ref().unwrap();
    assert_eq!(driven.instances[live.block].id, "input.valve");
    assert_eq!(live.param, "value");
    // the cycler still runs (it reads the piston) but drives nothing
    assert!(driven.find("controller").is_some());
    assert_eq!(alone.instances.len() + 1, driven.instances.len());
}

#[test]
fn a_port_nothing_drives_reads_the_input_in_both_builds() {
    let mut n = meter_out(json!({ "inputs": { "valve": { "port": "dcv.command", "start": 1 } } }));
    let conns = n["connections"].as_array_mut().unwrap();
    conns.retain(|c| c.get("to") != Some(&json!("dcv.command")));
    for drive in [Drive::Standalone, Drive::External] {
        let c = build(&n, drive).unwrap();
        assert_eq!(source_of(&c, "dcv.command"), "input.valve.value");
        let input = c.interface.input("valve").unwrap();
        assert_eq!(input.start, 1.0);
        assert_eq!(input.unit.text, "1", "default unit: the SI unit of the port");
    }
    // without the interface the same netlist is refused: the port is unconnected
    let mut bare = n.clone();
    bare["interface"] = json!({});
    assert_names(&build(&bare, Drive::External).unwrap_err(), &["dcv.command", "not connected"]);
}

#[test]
fn one_input_may_drive_several_ports() {
    let mut n = meter_out(json!({ "inputs": { "cmd": { "port": ["dcv.command", "extra.command"] } } }));
    n["components"].as_array_mut().unwrap().push(json!({ "id": "extra", "type": "valve_3_2", "params": { "C": "1 L/min/bar", "b": 0.3 } }));
    for c in [json!(["supply.port", "extra.P"]), json!(["extra.A", "vol.port"]), json!(["extra.E", "exhaust.port"])] {
        n["connections"].as_array_mut().unwrap().push(c);
    }
    n["components"].as_array_mut().unwrap().push(json!({ "id": "vol", "type": "chamber", "params": { "dead_volume": "1 L" } }));
    let alone = build(&n, Drive::Standalone).unwrap();
    assert_eq!(source_of(&alone, "dcv.command"), "controller.command");
    assert_eq!(source_of(&alone, "extra.command"), "input.cmd.value", "the unconnected port reads the input");
    let driven = build(&n, Drive::External).unwrap();
    assert_eq!(source_of(&driven, "dcv.command"), "input.cmd.value");
    assert_eq!(source_of(&driven, "extra.command"), "input.cmd.value");
}

#[test]
fn a_parameter_input_starts_at_the_parameters_value_in_its_unit() {
    let n = meter_out(json!({ "inputs": {
        "p_in": { "parameter": "supply.p", "unit": "barg", "description": "supply pressure" },
        "F": { "parameter": "piston.external_force" }
    } }));
    let mut flat = flatten(&n).unwrap();
    graph::apply_set(&mut flat, "p_supply=6 bar").unwrap();
    let c = graph::build_with(&flat, Drive::External).unwrap();
    let p = c.interface.input("p_in").unwrap();
    assert_eq!(p.start, 6e5, "the start follows --set through the expression");
    assert_eq!(p.unit.text, "barg");
    assert!((p.unit.from_si(6e5) - (6e5 - 101_325.0) / 1e5).abs() < 1e-12);
    assert_eq!(p.unit.to_si(1.0), 1e5 + 101_325.0);
    let live = p.live.as_ref().unwrap();
    assert_eq!((c.instances[live.block].id.as_str(), live.param), ("supply", "p"));
    assert!(live.spec.unwrap().check(-1.0).is_err(), "the parameter's range comes along");
    let f = c.interface.input("F").unwrap();
    assert_eq!((f.start, f.unit.text.as_str()), (0.0, "N"));
}

#[test]
fn outputs_bind_signals_recorded_values_and_running_totals() {
    let n = meter_out(json!({ "outputs": {
        "x": { "from": "piston.x", "unit": "mm", "description": "piston position" },
        "p_head": "head.p",
        "m_head": { "from": "head.m", "unit": "g" },
        "air": { "from": "supply.delivered", "unit": "g", "description": "air delivered since t = 0" },
        "T_rod": { "from": "rod.T", "unit": "degC" }
    } }));
    let c = build(&n, Drive::Standalone).unwrap();
    let names: Vec<&str> = c.interface.outputs.iter().map(|o| o.name.as_str()).collect();
    // (json! writes an object's keys sorted; the written order is kept, see below)
    assert_eq!(names, ["T_rod", "air", "m_head", "p_head", "x"], "outputs in the order written");
    let out = |name: &str| c.interface.output(name).unwrap();
    let piston = c.find("piston").unwrap();
    assert_eq!(out("x").source, OutputSource::Signal { block: piston, index: 0 });
    assert_eq!(out("x").unit.from_si(0.45), 450.0);
    assert_eq!(out("p_head").unit.text, "Pa");
    assert!(matches!(out("m_head").source, OutputSource::Recorded { .. }));
    assert!(matches!(out("air").source, OutputSource::Quadrature { .. }));
    assert!((out("T_rod").unit.from_si(293.15) - 20.0).abs() < 1e-12);
}

/// The netlist `meter_out` with the interface section as raw text (json!
/// would sort its keys).
fn with_raw_interface(raw: &str) -> String {
    meter_out(json!("INTERFACE")).to_string().replace("\"INTERFACE\"", raw)
}

#[test]
fn inputs_and_outputs_keep_the_order_the_file_writes_them_in() {
    let text = with_raw_interface(
        r#"{ "inputs": { "valve": { "port": "dcv.command" }, "F": { "parameter": "piston.external_force" } },
             "outputs": { "x": "piston.x", "p_rod": "rod.p", "air": "supply.delivered", "p_head": "head.p" } }"#,
    );
    let flat = graph::load(&Rig(text), Path::new("rig.json")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(flat.inputs.keys().collect::<Vec<_>>(), ["valve", "F"]);
    let c = graph::build_with(&flat, Drive::External).unwrap_or_else(|e| panic!("{e}"));
    let inputs: Vec<&str> = c.interface.inputs.iter().map(|i| i.name.as_str()).collect();
    let outputs: Vec<&str> = c.interface.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(inputs, ["valve", "F"]);
    assert_eq!(outputs, ["x", "p_rod", "air", "p_head"]);
    // written back (a written model, an FMU's resources) in the same order
    let netlist = graph::expand::parse(&with_raw_interface(r#"{ "outputs": { "x": "piston.x", "p_rod": "rod.p" } }"#), "rig.json").unwrap();
    let again = serde_json::to_string(&netlist.interface).unwrap();
    assert!(again.find("\"x\"").unwrap() < again.find("\"p_rod\"").unwrap(), "{again}");
}

#[test]
fn a_name_given_twice_is_refused() {
    for raw in [
        r#"{ "outputs": { "x": "piston.x", "p": "head.p", "x": "rod.p" } }"#,
        r#"{ "inputs": { "F": { "parameter": "piston.external_force" }, "F": { "port": "dcv.command" } } }"#,
    ] {
        let e = graph::load(&Rig(with_raw_interface(raw)), Path::new("rig.json"))
            .err()
            .unwrap_or_else(|| panic!("{raw}: accepted"))
            .to_string();
        assert_names(&e, &["rig.json", "is given twice"]);
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn start_values_take_units_and_expressions() {
    let mut n = meter_out(json!({ "inputs": {
        "p_set": { "port": "reg.p_set", "unit": "bar", "start": "= p_supply - 1 bar" }
    } }));
    n["components"].as_array_mut().unwrap().push(json!({ "id": "reg", "type": "proportional_pressure_valve",
        "params": { "C": "10 L/min/bar", "b": 0.3 } }));
    n["components"].as_array_mut().unwrap().push(json!({ "id": "out", "type": "chamber", "params": { "dead_volume": "1 L" } }));
    for c in [json!(["supply.port", "reg.P"]), json!(["reg.A", "out.port"]), json!(["reg.E", "exhaust.port"])] {
        n["connections"].as_array_mut().unwrap().push(c);
    }
    let c = match build(&n, Drive::External) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    };
    assert_eq!(c.interface.input("p_set").unwrap().start, 3e5);
    n["interface"]["inputs"]["p_set"]["start"] = json!("2.5 bar");
    assert_eq!(build(&n, Drive::External).unwrap().interface.input("p_set").unwrap().start, 2.5e5);
    n["interface"]["inputs"]["p_set"]["start"] = json!("25 mm");
    assert_names(&error_of(n.clone()), &["rig.json", "input \"p_set\"", "start is a length", "a pressure"]);
    n["interface"]["inputs"]["p_set"]["start"] = json!("= p_suply");
    assert_names(&error_of(n), &["input \"p_set\"", "p_suply"]);
}

#[test]
fn an_included_subsystems_inputs_and_outputs_are_not_kept() {
    let lib = json!({
        "parameters": { "stroke": "100 mm" },
        "components": [{ "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "= stroke" } }],
        "interface": { "ports": { "rod": "piston.rod" }, "outputs": { "x": "piston.x" } }
    });
    struct One(String);
    impl Loader for One {
        fn read(&self, _: &Path) -> Result<String, String> {
            Ok(self.0.clone())
        }
    }
    let top = json!({ "components": [{ "id": "cyl", "type": "subsystem", "file": "lib.json" }],
                      "interface": { "outputs": { "x_cyl": "cyl.piston.x" } } });
    let parsed = graph::expand::parse(&top.to_string(), "top.json").unwrap();
    let flat = graph::expand::flatten(&One(lib.to_string()), &parsed, Path::new(""), 0).unwrap();
    assert_eq!(flat.outputs.keys().collect::<Vec<_>>(), ["x_cyl"]);
    assert!(flat.inputs.is_empty());
}

#[test]
fn an_input_needs_exactly_one_binding() {
    let both = meter_out(json!({ "inputs": { "u": { "port": "dcv.command", "parameter": "supply.p" } } }));
    assert_names(&error_of(both), &["rig.json", "interface input \"u\"", "either \"port\"", "or \"parameter\""]);
    let neither = meter_out(json!({ "inputs": { "u": { "unit": "1" } } }));
    assert_names(&error_of(neither), &["interface input \"u\"", "either \"port\""]);
    let empty = meter_out(json!({ "inputs": { "u": { "port": [] } } }));
    assert_names(&error_of(empty), &["interface input \"u\"", "lists no port"]);
}

#[test]
fn ports_that_an_input_cannot_drive_are_named() {
    let cases = [
        ("dcvv.command", vec!["no component \"dcvv\""]),
        ("dcv.comand", vec!["\"dcv.comand\"", "no such port", "command"]),
        ("controller.command", vec!["\"controller.command\" is a signal output"]),
        ("dcv.P", vec!["\"dcv.P\" is a pneumatic port"]),
        ("dcv", vec!["not of the form ID.PORT"]),
    ];
    for (port, needles) in cases {
        let e = error_of(meter_out(json!({ "inputs": { "u": { "port": port } } })));
        assert_names(&e, &["rig.json", "interface input \"u\""]);
        assert_names(&e, &needles);
    }
    let twice = meter_out(json!({ "inputs": { "a": { "port": "dcv.command" }, "b": { "port": "dcv.command" } } }));
    assert_names(&error_of(twice), &["input \"b\"", "\"dcv.command\" is already driven by input \"a\""]);
}

#[test]
fn parameters_that_cannot_change_during_a_run_are_refused() {
    let e = error_of(meter_out(json!({ "inputs": { "bore": { "parameter": "head.bore" } } })));
    assert_names(&e, &["rig.json", "input \"bore\"", "\"head.bore\" cannot change during a run", "none"]);
    let e = error_of(meter_out(json!({ "inputs": { "q": { "parameter": "supply.q" } } })));
    assert_names(&e, &["\"supply.q\"", "those of \"supply\": p, T"]);
    let e = error_of(meter_out(json!({ "inputs": { "p": { "parameter": "supply.p", "start": "5 bar" } } })));
    assert_names(&e, &["input \"p\"", "starts at the parameter's value", "\"supply.p\""]);
    let e = error_of(meter_out(json!({ "inputs": { "a": { "parameter": "supply.p" }, "b": { "parameter": "supply.p" } } })));
    assert_names(&e, &["input \"b\"", "already set by input \"a\""]);
}

#[test]
fn units_of_the_wrong_dimension_or_unknown_are_refused() {
    let e = error_of(meter_out(json!({ "inputs": { "p": { "parameter": "supply.p", "unit": "mm" } } })));
    assert_names(&e, &["input \"p\"", "unit \"mm\" is a length", "a pressure"]);
    let e = error_of(meter_out(json!({ "outputs": { "x": { "from": "piston.x", "unit": "bar" } } })));
    assert_names(&e, &["interface output \"x\"", "unit \"bar\" is a pressure", "a length (m)"]);
    let e = error_of(meter_out(json!({ "outputs": { "x": { "from": "piston.x", "unit": "furlong" } } })));
    assert_names(&e, &["output \"x\"", "furlong"]);
    let e = error_of(meter_out(json!({ "inputs": { "u": { "port": "dcv.command", "unit": "bar" } } })));
    assert_names(&e, &["input \"u\"", "a dimensionless number"]);
}

#[test]
fn names_are_identifiers_in_one_namespace_with_the_parameters() {
    let e = error_of(meter_out(json!({ "outputs": { "stroke": "piston.x" } })));
    assert_names(&e, &["output \"stroke\"", "parameter of the netlist"]);
    let e = error_of(meter_out(json!({ "inputs": { "x": { "port": "dcv.command" } }, "outputs": { "x": "piston.x" } })));
    assert_names(&e, &["output \"x\"", "also the name of an input"]);
    let e = error_of(meter_out(json!({ "outputs": { "2x\u{1b}[31m": "piston.x" } })));
    assert_names(&e, &["output \"2x\\u{1b}[31m\"", "letter or '_'"]);
}

#[test]
fn an_unknown_output_lists_what_the_component_records() {
    let e = error_of(meter_out(json!({ "outputs": { "pos": "piston.position" } })));
    assert_names(&e, &["rig.json", "output \"pos\"", "\"piston\" records no \"position\"", "x, v"]);
    let e = error_of(meter_out(json!({ "outputs": { "pos": "pistn.x" } })));
    assert_names(&e, &["output \"pos\"", "no component \"pistn\""]);
}

#[test]
fn misspelt_keys_are_located_in_the_file() {
    let text = "{\n \"components\": [],\n \"interface\": {\n  \"inputs\": { \"u\": { \"prot\": \"dcv.command\" } }\n }\n}";
    let e = graph::expand::parse(text, "m.json").unwrap_err().to_string();
    assert_names(&e, &["m.json:4:", "prot", "port"]);
    let text =
        "{\n \"components\": [],\n \"interface\": {\n  \"outputs\": {\n   \"x\": { \"from\": \"piston.x\", \"units\": \"mm\" } }\n }\n}";
    let e = graph::expand::parse(text, "m.json").unwrap_err().to_string();
    assert_names(&e, &["m.json:5:", "units", "unit"]);
    let text = "{\n \"components\": [],\n \"interface\": { \"outputs\": { \"x\": 3 } }\n}";
    let e = graph::expand::parse(text, "m.json").unwrap_err().to_string();
    assert_names(&e, &["m.json:3:", "\"id.signal\" or {\"from\""]);
}

#[test]
fn the_schema_describes_inputs_and_outputs() {
    let schema = graph::netlist::schema();
    let interface = schema.pointer("/$defs/Interface/properties").expect("Interface in the schema");
    for key in ["ports", "params", "inputs", "outputs"] {
        assert!(interface.get(key).is_some(), "no {key} in {interface:#}");
    }
    let input = schema.pointer("/$defs/InputDecl/properties").expect("InputDecl in the schema");
    for key in ["port", "parameter", "unit", "start", "description"] {
        assert!(input.get(key).is_some(), "no {key} in {input:#}");
    }
    assert_eq!(schema.pointer("/$defs/InputDecl/additionalProperties"), Some(&json!(false)));
}
