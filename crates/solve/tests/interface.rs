//! The netlist's interface at run time, on the shipped meter-out circuit:
//! a valve-command input replaces the cycler only when the model is driven
//! from outside, a supply-pressure input gives the run `--set supply.p`
//! gives, values outside a parameter's range are refused, and the outputs
//! report the recorded values in SI.

mod common;

use common::{flat_from_json, last, models_dir, series};
use graph::Drive;
use serde_json::json;
use solve::{Model, SimOptions};

/// models/meter_out.json with an interface section.
fn meter_out(interface: serde_json::Value) -> graph::FlatNetlist {
    let text = std::fs::read_to_string(models_dir().join("meter_out.json")).unwrap();
    let mut netlist: serde_json::Value = serde_json::from_str(&text).unwrap();
    netlist["interface"] = interface;
    flat_from_json(&netlist)
}

fn model(flat: &graph::FlatNetlist, drive: Drive) -> Model {
    Model::new(graph::build_with(flat, drive).unwrap_or_else(|e| panic!("build: {e}")))
}

/// The netlist's own settings (three cycles), with `t_end` if given.
fn options(flat: &graph::FlatNetlist, t_end: Option<f64>) -> SimOptions {
    let circuit = graph::build(flat).unwrap();
    let mut opts = solve::options_from(&circuit.simulation).unwrap();
    if let Some(t) = t_end {
        opts.t_end = t;
    }
    opts
}

fn valve_input() -> serde_json::Value {
    json!({ "inputs": { "valve": { "port": "dcv.command", "start": 0 } },
            "outputs": { "x": { "from": "piston.x", "unit": "mm" }, "p_rod": { "from": "rod.p", "unit": "bar" },
                         "air": { "from": "supply.delivered", "unit": "g" } } })
}

#[test]
fn a_standalone_run_keeps_the_cycler_and_a_driven_one_holds_the_input() {
    let flat = meter_out(valve_input());
    let opts = options(&flat, None);
    let plain = solve::simulate(&mut Model::new(graph::build(&meter_out(json!({}))).unwrap()), &opts).unwrap();
    let alone = solve::simulate(&mut model(&flat, Drive::Standalone), &opts).unwrap();
    assert_eq!(alone.cycles.len(), 3);
    let totals = |r: &solve::SimResult| r.cycles.iter().map(|c| c.total).collect::<Vec<_>>();
    assert_eq!(totals(&alone), totals(&plain), "declaring an input changes nothing in a standalone run");

    // driven from outside, the valve holds the input: released (0), the piston stays retracted
    let mut held = model(&flat, Drive::External);
    let released = solve::simulate(&mut held, &options(&flat, Some(1.0))).unwrap();
    assert!(released.cycles.is_empty());
    assert!(series(&released, "piston.x").iter().all(|&(_, x)| x < 1e-9), "the piston moved with the valve released");
    // actuated (1) from the start, the piston extends to its stop and stays there
    let mut pushed = model(&flat, Drive::External);
    pushed.set_input(0, 1.0).unwrap();
    let extended = solve::simulate(&mut pushed, &options(&flat, Some(3.0))).unwrap();
    assert!((last(&extended, "piston.x") - 0.45).abs() < 1e-9, "x = {}", last(&extended, "piston.x"));
    assert_eq!(last(&extended, "input.valve.value"), 1.0);
    // the cycler did see the stroke end, but commanded nothing: no cycle completed
    assert!(extended.cycles.is_empty());
}

#[test]
fn a_supply_pressure_input_runs_as_the_same_value_set_in_the_netlist() {
    let interface = json!({ "inputs": { "p_supply": { "parameter": "supply.p", "unit": "bar" } } });
    let flat = meter_out(interface);
    let opts = options(&flat, None);
    let mut driven = model(&flat, Drive::External);
    assert_eq!(driven.input_value(0), 4e5, "starts at the netlist's value");
    driven.set_input(0, 6e5).unwrap();
    let by_input = solve::simulate(&mut driven, &opts).unwrap();
    let mut set = flat.clone();
    graph::apply_set(&mut set, "supply.p=6 bar").unwrap();
    let by_set = solve::simulate(&mut Model::new(graph::build(&set).unwrap()), &opts).unwrap();
    assert_eq!(by_input.cycles.len(), 3);
    for (a, b) in by_input.cycles.iter().zip(&by_set.cycles) {
        assert_eq!(a.total, b.total, "cycle {a:?} against {b:?}");
    }
}

#[test]
fn values_outside_the_parameters_range_are_refused_and_leave_the_input_as_it_was() {
    let flat = meter_out(json!({ "inputs": { "p_supply": { "parameter": "supply.p", "unit": "barg" },
                                             "valve": { "port": "dcv.command" } } }));
    let mut m = model(&flat, Drive::External);
    let k = m.circuit.interface.inputs.iter().position(|i| i.name == "p_supply").unwrap();
    let e = m.set_input(k, -1e5).unwrap_err().to_string();
    assert!(e.starts_with("input \"p_supply\" = -2.01325 barg: must be > 0"), "{e}");
    assert_eq!(m.input_value(k), 4e5);
    let e = m.set_input(k, f64::NAN).unwrap_err().to_string();
    assert!(e.contains("must be finite"), "{e}");
    let v = 1 - k;
    assert!(m.set_input(v, f64::INFINITY).is_err());
    m.set_input(v, -7.5).unwrap(); // a port input takes any finite value
    assert_eq!(m.input_value(v), -7.5);
}

#[test]
fn outputs_report_the_recorded_values_in_si() {
    let flat = meter_out(valve_input());
    let mut m = model(&flat, Drive::External);
    solve::rest::apply(&mut m).unwrap();
    let mut y = m.initial_state();
    let n = m.n_states;
    let quad = m.circuit.interface.output("air").map(|o| o.source);
    if let Some(graph::interface::OutputSource::Quadrature { .. }) = quad {
        // make the running total visible: it is the state after the block states
        for v in y[n..].iter_mut() {
            *v = 2.5e-3;
        }
    } else {
        panic!("air is not a running total: {quad:?}");
    }
    let mut out = vec![0.0; m.circuit.interface.outputs.len()];
    m.interface_outputs(0.0, &y, &mut out).unwrap();
    let mut row = vec![None; m.n_outputs];
    m.record(0.0, &y, &mut row).unwrap();
    let column = |name: &str| row[m.output_names().iter().position(|c| c == name).unwrap()].unwrap();
    let by_name = |name: &str| out[m.circuit.interface.outputs.iter().position(|o| o.name == name).unwrap()];
    assert_eq!(by_name("x"), column("piston.x"));
    assert_eq!(by_name("p_rod"), column("rod.p"));
    assert!(by_name("p_rod") > 3.9e5, "the rod chamber rests at the supply pressure: {}", by_name("p_rod"));
    assert_eq!(by_name("air"), 2.5e-3);
}

#[test]
fn the_shipped_models_declare_interfaces_that_bind_in_both_builds() {
    for (file, inputs, outputs) in
        [("meter_out.json", 0, 9), ("position_control.json", 2, 7), ("mid_stop_5_3.json", 2, 6), ("sequence_ab.json", 1, 6)]
    {
        let flat = common::flat_from_model(file, &[]);
        for drive in [Drive::Standalone, Drive::External] {
            let c = graph::build_with(&flat, drive).unwrap_or_else(|e| panic!("{file}: {e}"));
            assert_eq!((c.interface.inputs.len(), c.interface.outputs.len()), (inputs, outputs), "{file}");
            for o in &c.interface.outputs {
                assert!(o.description.is_some() && !o.unit.text.is_empty(), "{file}: output {} needs a unit and a description", o.name);
            }
            for i in &c.interface.inputs {
                assert!(i.description.is_some() && !i.unit.text.is_empty(), "{file}: input {} needs a unit and a description", i.name);
                assert_eq!(i.live.is_some(), drive == Drive::External || matches!(i.binding, graph::interface::Binding::Parameter(_)));
            }
        }
    }
}

#[test]
fn the_position_control_plant_follows_its_valve_input_and_load() {
    let flat = common::flat_from_model("position_control.json", &[]);
    let run = |u: f64, load: f64| {
        let mut m = model(&flat, Drive::External);
        // inputs in the netlist's order (u, F_load), found by name
        let index = |name: &str| flat.inputs.keys().position(|k| k == name).expect(name);
        m.set_input(index("F_load"), load).unwrap();
        m.set_input(index("u"), u).unwrap();
        let mut opts = options(&flat, Some(0.2));
        opts.sample_interval = 0.01;
        last(&solve::simulate(&mut m, &opts).unwrap(), "cyl.piston.x")
    };
    // the PID and its set point are cut off: with the valve centred the piston
    // only creeps (the centre leak and the unequal areas), by under 2 mm
    let centred = run(0.0, 0.0);
    assert!(centred.abs() < 2e-3, "x = {centred} m with the valve centred");
    let open = run(0.3, 0.0);
    assert!(open > 0.03 && open < 0.199, "x = {open} m after 0.2 s with the valve 30 % open");
    let loaded = run(0.3, -150.0);
    assert!(loaded < open - 1e-3, "a load against the motion slows it: {loaded} against {open}");
    assert!(run(-0.3, 0.0).abs() < 1e-9, "opened the other way, the piston stays on its retracted stop");
}
