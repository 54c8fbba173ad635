//! Bad input to the blocks of the library: each mistake is refused when the
//! circuit is built, with one line that names the component and the
//! parameter (or the ports) at fault.

use graph::{FlatNetlist, Loader};
use serde_json::{json, Value};
use std::path::Path;

struct NoFiles;
impl Loader for NoFiles {
    fn read(&self, path: &Path) -> Result<String, String> {
        Err(format!("no such file {}", path.display()))
    }
}

fn build(netlist: &Value) -> Result<graph::Circuit, String> {
    let parsed = graph::expand::parse(&netlist.to_string(), "inline.json").map_err(|e| e.to_string())?;
    let flat: FlatNetlist = graph::expand::flatten(&NoFiles, &parsed, Path::new(""), 0).map_err(|e| e.to_string())?;
    graph::build(&flat).map_err(|e| e.to_string())
}

fn error_of(netlist: Value, needles: &[&str]) {
    let e = match build(&netlist) {
        Ok(_) => panic!("expected an error for {netlist:#}"),
        Err(e) => e,
    };
    assert!(!e.contains('\n'), "one line: {e}");
    for n in needles {
        assert!(e.contains(n), "message does not name {n:?}: {e}");
    }
}

/// Supply, regulator, a line volume and an exhaust: valid as given.
fn regulated(p_set: &str) -> Value {
    json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "7 bar" } },
            { "id": "exhaust", "type": "atmosphere", "params": {} },
            { "id": "filter", "type": "conductance", "params": { "C": "200 L/min/bar", "b": 0.4 } },
            { "id": "reg", "type": "pressure_regulator", "params": { "p_set": p_set, "C": "50 L/min/bar", "b": 0.3 } },
            { "id": "line", "type": "chamber", "params": { "dead_volume": "50 cm3" } }
        ],
        "connections": [["supply.port", "filter.a"], ["filter.b", "reg.P"], ["reg.A", "line.port"], ["reg.E", "exhaust.port"]]
    })
}

#[test]
fn a_regulator_set_above_its_supply_is_refused() {
    assert!(build(&regulated("5 bar")).is_ok());
    error_of(regulated("8 bar"), &["component \"reg\"", "parameter \"p_set\"", "supply.p", "7.0000 bar"]);
    // gauge and absolute are compared as absolute pressures
    error_of(regulated("6 barg"), &["reg", "p_set"]);
}

#[test]
fn a_signal_port_wired_to_a_pneumatic_port_is_refused() {
    let mut n = regulated("5 bar");
    n["components"].as_array_mut().unwrap().push(json!({ "id": "sensor", "type": "pressure_sensor", "params": {} }));
    n["connections"].as_array_mut().unwrap().push(json!(["sensor.port", "line.port"]));
    assert!(build(&n).is_ok());
    n["connections"].as_array_mut().unwrap().push(json!(["sensor.p", "reg.A"]));
    error_of(n, &["\"sensor.p\" (signal)", "\"reg.A\" (pneumatic)", "different domains"]);
}

fn sequence(transitions: &[&str], actions: &[&str]) -> Value {
    json!({
        "components": [
            { "id": "start", "type": "schedule", "params": { "times": "1 s", "values": "1" } },
            { "id": "seq", "type": "sequencer",
              "params": { "inputs": "go", "outputs": "A", "transitions": transitions, "actions": actions } }
        ],
        "connections": [{ "from": "start.command", "to": "seq.go" }]
    })
}

#[test]
fn a_sequencer_with_unreachable_steps_or_unknown_signals_is_refused() {
    assert!(build(&sequence(&["0 -> 1 : go", "1 -> 0 : after 1 s"], &["A : 1"])).is_ok());
    error_of(sequence(&["0 -> 1 : go", "2 -> 0 : go"], &[]), &["component \"seq\"", "parameter \"transitions\"", "2", "cannot be reached"]);
    error_of(sequence(&["0 -> 1 : go & a1"], &[]), &["component \"seq\"", "parameter \"transitions\"", "\"a1\" is not an input"]);
    error_of(sequence(&["0 -> 1 : go"], &["B : 1"]), &["component \"seq\"", "parameter \"actions\"", "\"B\" is not an output"]);
    error_of(sequence(&["0 -> 1 go"], &[]), &["component \"seq\"", "parameter \"transitions\"", "S -> T : condition"]);
    // its ports are named by its parameters: an unknown one is named with the ones that exist
    let mut n = sequence(&["0 -> 1 : go"], &["A : 1"]);
    n["connections"].as_array_mut().unwrap().push(json!({ "from": "start.command", "to": "seq.stop" }));
    error_of(n, &["\"seq.stop\"", "go, A"]);
}

#[test]
fn a_hose_with_no_segments_is_refused() {
    let hose = |segments: Value, inertia: &str| {
        json!({
            "components": [
                { "id": "supply", "type": "pressure_source", "params": { "p": "7 bar" } },
                { "id": "hose", "type": "tube", "params": { "length": "5 m", "diameter": "6 mm", "segments": segments, "inertia": inertia } },
                { "id": "tank", "type": "chamber", "params": { "dead_volume": "1 L" } }
            ],
            "connections": [["supply.port", "hose.a"], ["hose.b", "tank.port"]]
        })
    };
    assert!(build(&hose(json!(10), "yes")).is_ok());
    error_of(hose(json!(0), "no"), &["component \"hose\"", "parameter \"segments\"", "at least 1"]);
    error_of(hose(json!(1), "yes"), &["component \"hose\"", "parameter \"segments\"", "inertia"]);
    error_of(hose(json!(2.5), "no"), &["component \"hose\"", "\"segments\"", "whole number"]);
}

#[test]
fn bad_valve_and_load_settings_name_their_parameter() {
    let one = |id: &str, ty: &str, params: Value| json!({ "components": [{ "id": id, "type": ty, "params": params }] });
    let c = |extra: Value| {
        let mut p = json!({ "C": "50 L/min/bar", "b": 0.3 });
        p.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        p
    };
    error_of(one("v", "valve_5_3", c(json!({ "centre": "open" }))), &["component \"v\"", "\"centre\"", "closed, exhaust, pressure"]);
    error_of(one("v", "valve_5_3", c(json!({ "initial_position": "14" }))), &["component \"v\"", "initial_position", "detent"]);
    error_of(one("v", "valve_5_3", c(json!({ "actuation": "pilot", "pilot_hysteresis": "3 bar" }))), &["pilot_hysteresis"]);
    error_of(one("l", "load", json!({ "angle": "120 deg" })), &["component \"l\"", "\"angle\""]);
    error_of(one("c", "cushion", c(json!({ "cushion_length": "20 mm", "C_needle": "1 L/min/bar" }))), &["component \"c\"", "\"stroke\""]);
    error_of(one("p", "pid", json!({ "u_min": 1, "u_max": -1 })), &["component \"p\"", "u_max"]);
    error_of(one("t", "timer", json!({ "mode": "on_delay" })), &["component \"t\"", "\"delay\""]);
}
