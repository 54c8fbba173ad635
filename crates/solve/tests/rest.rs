//! The rest state before t = 0 (`"initial": "rest"`, `solve::rest`): the
//! paper's meter-out circuit at any supply pressure, and the cases the rule
//! must keep (closed volumes, explicit values) or refuse (a chamber open to
//! two pressure levels, a piston with nowhere to rest).

mod common;

use common::*;
use serde_json::json;

/// Build a model of `flat` and compute its rest state.
fn rest_of(flat: &graph::FlatNetlist) -> Result<(solve::Model, solve::RestReport), String> {
    let circuit = graph::build(flat).map_err(|e| e.to_string())?;
    let mut model = solve::Model::new(circuit);
    let report = solve::rest::apply(&mut model).map_err(|e| e.to_string())?;
    Ok((model, report))
}

fn value(report: &solve::RestReport, id: &str, param: &str) -> Option<f64> {
    report.values.iter().find(|v| v.id == id && v.param == param).map(|v| v.value)
}

#[test]
fn meter_out_rod_chamber_rests_at_the_supply_pressure_head_at_atmosphere() {
    for tenth_bar in (30..=80).step_by(5) {
        let ps = tenth_bar as f64 * 1e4;
        let flat = flat_from_model("meter_out.json", &[&format!("supply.p={ps} Pa")]);
        let (_, report) = rest_of(&flat).unwrap();
        let rod = value(&report, "rod", "p0").expect("rod.p0 chosen");
        let head = value(&report, "head", "p0").expect("head.p0 chosen");
        assert!(rel(rod, ps) < 1e-9, "rod {rod} against supply {ps}");
        assert!(rel(head, 0.98e5) < 1e-9, "head {head} against atmosphere");
        assert_eq!(value(&report, "rod", "T0"), Some(292.0));
        assert_eq!(value(&report, "head", "T0"), Some(292.0));
        assert_eq!(value(&report, "piston", "x0"), Some(0.0));
        // the simulation starts there
        let res = run_with(&flat, |o| o.t_end = 1e-3);
        let p_rod = series(&res, "rod.p")[0].1;
        assert!(rel(p_rod, ps) < 1e-9, "first sample of rod.p {p_rod} against {ps}");
    }
}

#[test]
fn the_rest_state_follows_the_supply_temperature_and_atmosphere() {
    let flat = flat_from_model("meter_out.json", &["supply.T=300 K", "p_atm=1 bar"]);
    let (_, report) = rest_of(&flat).unwrap();
    assert_eq!(value(&report, "rod", "T0"), Some(300.0));
    assert!(rel(value(&report, "head", "p0").unwrap(), 1e5) < 1e-12);
}

#[test]
fn explicit_initial_values_are_kept() {
    let flat = flat_from_model("meter_out.json", &["rod.p0=3 bar", "piston.x0=100 mm"]);
    let (_, report) = rest_of(&flat).unwrap();
    assert_eq!(value(&report, "rod", "p0"), None);
    assert_eq!(value(&report, "rod", "T0"), Some(292.0), "T0 stays free and follows the supply");
    assert_eq!(value(&report, "piston", "x0"), None);
    let res = run_with(&flat, |o| o.t_end = 1e-3);
    assert!(rel(series(&res, "rod.p")[0].1, 3e5) < 1e-9);
    assert!((series(&res, "piston.x")[0].1 - 0.1).abs() < 1e-12);
}

#[test]
fn the_subsystem_circuits_rest_like_the_flat_one() {
    let flat = flat_from_model("meter_out_subsystem.json", &["supply.p=6 bar"]);
    let (_, report) = rest_of(&flat).unwrap();
    assert!(rel(value(&report, "cyl.rod", "p0").unwrap(), 6e5) < 1e-9);
    assert!(rel(value(&report, "cyl.head", "p0").unwrap(), 0.98e5) < 1e-9);
}

/// A rigid tank behind `valve` from a 6 bar supply; the tank's init as given.
fn tank_behind(valve: serde_json::Value, init: serde_json::Value) -> graph::FlatNetlist {
    flat_from_json(&json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar", "T": "300 K" } },
            valve,
            { "id": "tank", "type": "chamber", "params": { "dead_volume": "1 L" }, "init": init },
            { "id": "cmd", "type": "schedule", "params": { "times": [1.0], "values": [1.0] } }
        ],
        "connections": [["supply.port", "v.a"], ["v.b", "tank.port"], { "from": "cmd.command", "to": "v.command" }],
        "simulation": { "initial": "rest", "t_end": "0.5 s" }
    }))
}

#[test]
fn a_closed_volume_keeps_its_value() {
    // a normally closed 2/2 valve, released at rest
    let flat =
        tank_behind(json!({ "id": "v", "type": "valve_2_2", "params": { "C": "10 L/min/bar", "b": 0.3 } }), json!({ "p0": "2 bar" }));
    let (_, report) = rest_of(&flat).unwrap();
    assert!(report.values.is_empty(), "{report:?}");
    // with nothing given, the default stays too
    let flat = tank_behind(json!({ "id": "v", "type": "valve_2_2", "params": { "C": "10 L/min/bar", "b": 0.3 } }), json!({}));
    assert!(rest_of(&flat).unwrap().1.values.is_empty());
}

#[test]
fn an_open_valve_at_rest_fills_the_volume() {
    // normally open: the tank rests at the supply state
    let v = json!({ "id": "v", "type": "valve_2_2", "params": { "C": "10 L/min/bar", "b": 0.3, "normally_open": "yes" } });
    let (_, report) = rest_of(&tank_behind(v, json!({}))).unwrap();
    assert_eq!(value(&report, "tank", "p0"), Some(6e5));
    assert_eq!(value(&report, "tank", "T0"), Some(300.0));
}

#[test]
fn a_one_way_path_fills_only_from_below() {
    let check = |init: serde_json::Value| {
        let flat = flat_from_json(&json!({
            "components": [
                { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
                { "id": "v", "type": "check_valve", "params": { "C": "10 L/min/bar", "b": 0.3 } },
                { "id": "tank", "type": "chamber", "params": { "dead_volume": "1 L" }, "init": init }
            ],
            "connections": [["supply.port", "v.a"], ["v.b", "tank.port"]],
            "simulation": { "initial": "rest" }
        }));
        rest_of(&flat).unwrap().1
    };
    // free pressure: the check valve lets gas in until the tank is at the supply
    assert_eq!(value(&check(json!({})), "tank", "p0"), Some(6e5));
}

#[test]
fn a_chamber_open_to_two_pressure_levels_rests_in_the_flow_equilibrium() {
    // supply 6 bar → C1 = 10 → tank → C2 = 1 → vent 0.98 bar: gas flows through the tank for ever
    let flat = flat_from_json(&json!({
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar", "T": "293.15 K" } },
            { "id": "vent", "type": "atmosphere", "params": { "p": "0.98 bar", "T": "293.15 K" } },
            { "id": "in", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } },
            { "id": "out", "type": "conductance", "params": { "C": "1 L/min/bar", "b": 0.3 } },
            { "id": "tank", "type": "chamber", "params": { "dead_volume": "1 L", "T_wall": "293.15 K" } }
        ],
        "connections": [["supply.port", "in.a"], ["in.b", "tank.port"], ["tank.port", "out.a"], ["out.b", "vent.port"]],
        "simulation": { "initial": "rest", "t_end": "2 s" }
    }));
    let (_, report) = rest_of(&flat).unwrap();
    let p = value(&report, "tank", "p0").expect("tank.p0 chosen");
    let t = value(&report, "tank", "T0").expect("tank.T0 chosen");
    // ISO 6358 (paper Eq. 33-35) by hand: the outflow is choked (0.98/p < b),
    // the inflow subsonic; in steady state they are equal:
    //   C1 ps √(T_N/T_s) ω(p/ps) = C2 p √(T_N/T)
    let (ps, ts, b): (f64, f64, f64) = (6e5, 293.15, 0.3);
    let omega = |r: f64| (1.0 - ((r - b) / (1.0 - b)).powi(2)).sqrt();
    let inflow = 10.0 * ps * (1.0 / ts).sqrt() * omega(p / ps);
    let outflow = 1.0 * p * (1.0 / t).sqrt();
    assert!(rel(inflow, outflow) < 1e-6, "in {inflow} out {outflow} at p = {p} Pa, T = {t} K");
    assert!(p > 5.5e5 && p < 6e5, "{p}");
    // and the simulation starting there stays there
    let res = run(&flat);
    let ps_series = series(&res, "tank.p");
    let drift = ps_series.iter().map(|&(_, v)| rel(v, p)).fold(0.0, f64::max);
    assert!(drift < 1e-7, "drift {drift}");
}

#[test]
fn a_piston_pushed_out_rests_on_the_upper_stop_and_a_spring_in_between_is_refused() {
    let cylinder = |spring: serde_json::Value| {
        let mut components = vec![
            json!({ "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } }),
            json!({ "id": "v", "type": "conductance", "params": { "C": "10 L/min/bar", "b": 0.3 } }),
            json!({ "id": "head", "type": "chamber", "params": { "dead_volume": "10 cm3", "bore": "40 mm" } }),
            json!({ "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "200 mm" } }),
        ];
        let mut connections = vec![json!(["supply.port", "v.a"]), json!(["v.b", "head.port"]), json!(["head.piston", "piston.rod"])];
        if !spring.is_null() {
            components.push(spring);
            connections.push(json!(["spring.rod", "piston.rod"]));
        }
        flat_from_json(&json!({ "components": components, "connections": connections, "simulation": { "initial": "rest" } }))
    };
    let (_, report) = rest_of(&cylinder(serde_json::Value::Null)).unwrap();
    assert_eq!(value(&report, "piston", "x0"), Some(0.2));
    // a spring that pushes back harder than the gas at the upper stop: rests in between
    let spring = json!({ "id": "spring", "type": "spring", "params": { "stiffness": "5 N/mm", "preload": "0 N", "direction": "retract" } });
    let e = rest_of(&cylinder(spring)).unwrap_err();
    assert!(e.contains("\"piston\"") && e.contains("x0") && e.contains("between"), "{e}");
}

/// The meter-out circuit with a seal leak of conductance `c` between the chambers.
fn meter_out_with_leak(c: &str) -> graph::FlatNetlist {
    let mut flat = flat_from_model("meter_out.json", &[]);
    let text = json!({
        "components": [{ "id": "leak", "type": "conductance", "params": { "C": c, "b": 0.3 } }],
        "connections": []
    });
    let extra = flat_from_json(&text);
    flat.components.extend(extra.components);
    flat.connections.push(("leak.a".into(), "head.port".into()));
    flat.connections.push(("leak.b".into(), "rod.port".into()));
    flat
}

#[test]
fn a_seal_leak_does_not_move_the_rest_pressures_a_wide_bypass_does() {
    // 0.3 L/(min bar) against 490 L/(min bar) valves: the leak path is neglected
    let (_, report) = rest_of(&meter_out_with_leak("0.3 L/min/bar")).unwrap();
    assert_eq!(value(&report, "rod", "p0"), Some(4e5));
    assert_eq!(value(&report, "head", "p0"), Some(0.98e5));
    // a bypass as wide as the valves: the chambers rest in the flow equilibrium,
    // strictly between the two levels, and stay there when simulated at rest
    let (_, report) = rest_of(&meter_out_with_leak("200 L/min/bar")).unwrap();
    let (rod, head) = (value(&report, "rod", "p0").unwrap(), value(&report, "head", "p0").unwrap());
    assert!(head > 0.98e5 * 1.001 && rod < 4e5 * 0.999 && head < rod, "head {head} rod {rod}");
}
