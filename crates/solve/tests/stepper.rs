//! Stepping a model from outside (`solve::Stepper`), on the shipped
//! meter-out circuit: communication steps of 1 ms reproduce the run
//! `solve::simulate` makes by itself; the 5/2 valve driven from outside by
//! the cycler's schedule gives the cycler's stroke times; an input set to the
//! value it has changes nothing, bit for bit; a copy of a stepper goes on
//! exactly like the original; an input that makes the model fail is
//! reported as an error at the step, not a panic.

mod common;

use common::{flat_from_model, series};
use graph::Drive;
use serde_json::json;
use solve::{Model, SimOptions, Stepper};

fn options(flat: &graph::FlatNetlist) -> SimOptions {
    solve::options_from(&graph::build(flat).unwrap().simulation).unwrap()
}

fn stepper(flat: &graph::FlatNetlist, drive: Drive) -> Stepper {
    Stepper::new(Model::new(graph::build_with(flat, drive).unwrap()), &options(flat)).unwrap_or_else(|e| panic!("{e}"))
}

/// Output `name` of the stepper now [SI].
fn output(s: &mut Stepper, name: &str) -> f64 {
    let k = s.model().circuit.interface.outputs.iter().position(|o| o.name == name).unwrap();
    let mut out = vec![0.0; s.model().circuit.interface.outputs.len()];
    s.outputs(&mut out).unwrap();
    out[k]
}

/// meter_out.json with the 5/2 valve's command as an input.
fn meter_out_with_valve_input() -> graph::FlatNetlist {
    let text = std::fs::read_to_string(common::models_dir().join("meter_out.json")).unwrap();
    let mut netlist: serde_json::Value = serde_json::from_str(&text).unwrap();
    netlist["interface"]["inputs"] = json!({ "valve": { "port": "dcv.command", "start": 0 } });
    common::flat_from_json(&netlist)
}

#[test]
fn millisecond_steps_reproduce_the_standalone_run() {
    let flat = flat_from_model("meter_out.json", &[]);
    let mut opts = options(&flat);
    opts.t_end = 3.0;
    opts.cycles = None;
    let reference = solve::simulate(&mut Model::new(graph::build(&flat).unwrap()), &opts).unwrap();
    let x_ref = series(&reference, "piston.x");
    let mut s = stepper(&flat, Drive::External); // no inputs: the cycler drives the valve either way
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for k in 1..=3000 {
        let t = k as f64 * 1e-3;
        s.advance_to(t).unwrap();
        assert_eq!(s.t(), t, "the stepper stops at the communication point");
        // the reference is sampled on the same grid
        let Some(&(_, x)) = x_ref.iter().find(|(tr, _)| (tr - t).abs() < 1e-9) else { continue };
        worst = worst.max((output(&mut s, "x") - x).abs());
        compared += 1;
    }
    assert!(compared > 2900, "{compared} points compared");
    // both integrate to rtol = atol = 1e-4 (meter_out.json): they differ by the
    // integration error of different step sequences, far below a millimetre
    assert!(worst < 2e-4, "largest difference in x: {worst} m");
    let cycles = s.take_cycles();
    assert_eq!(cycles.len(), reference.cycles.iter().filter(|c| c.start + c.total <= 3.0).count());
    for (a, b) in cycles.iter().zip(&reference.cycles) {
        assert!((a.total - b.total).abs() < 1e-3 * b.total, "cycle {a:?} against {b:?}");
    }
}

#[test]
fn the_valve_driven_from_outside_by_the_cyclers_schedule_gives_the_cyclers_stroke_times() {
    let flat = meter_out_with_valve_input();
    let mut opts = options(&flat);
    opts.cycles = Some(3);
    opts.t_end = 60.0;
    let reference = solve::simulate(&mut Model::new(graph::build(&flat).unwrap()), &opts).unwrap();
    assert_eq!(reference.cycles.len(), 3);
    // the cycler's switching times: (time, command); a master that knows
    // them (FMPy with an input table) lands a communication point on each
    let mut schedule = Vec::new();
    for c in &reference.cycles {
        schedule.push((c.start, 1.0));
        schedule.push((c.retract_start, 0.0));
    }
    let mut s = stepper(&flat, Drive::External);
    let h = 1e-3;
    let (stroke, tol) = (0.45, 1e-5);
    let (mut x_prev, mut v_prev, mut t_prev) = (output(&mut s, "x"), 0.0, 0.0);
    let (mut extend_end, mut retract_end) = (Vec::new(), Vec::new());
    let mut next = 0;
    let t_last = reference.cycles[2].start + reference.cycles[2].total;
    while s.t() < t_last {
        if next < schedule.len() && schedule[next].0 <= s.t() {
            s.set_input(0, schedule[next].1).unwrap();
            next += 1;
        }
        let t_next = (s.t() + h).min(schedule.get(next).map_or(f64::INFINITY, |e| e.0));
        s.advance_to(t_next).unwrap();
        // the switch crossings, extrapolated from the communication point
        // before with the velocity there (the piston hits its stop within the
        // step, so a straight line to the next point would be late by up to a step)
        let (x, v) = (output(&mut s, "x"), output(&mut s, "v"));
        let crossing = |level: f64| t_prev + (level - x_prev) / v_prev;
        if x_prev < stroke - tol && x >= stroke - tol {
            extend_end.push(crossing(stroke - tol));
        }
        if x_prev > tol && x <= tol {
            retract_end.push(crossing(tol));
        }
        (x_prev, v_prev, t_prev) = (x, v, s.t());
    }
    assert_eq!((extend_end.len(), retract_end.len()), (3, 3));
    let mut worst = 0.0f64;
    for (k, c) in reference.cycles.iter().enumerate() {
        let (extend, retract) = (extend_end[k] - c.start, retract_end[k] - c.retract_start);
        // issue 26 asks for 0.1 %; measured: at most 1.7e-4 relative (docs/fmu.md,
        // compared below), the integration error of two step sequences at rtol 1e-4
        assert!((extend - c.extend).abs() < 1e-3 * c.extend, "extend {extend} s against the cycler's {} s", c.extend);
        assert!((retract - c.retract).abs() < 1e-3 * c.retract, "retract {retract} s against the cycler's {} s", c.retract);
        worst = worst.max((extend / c.extend - 1.0).abs()).max((retract / c.retract - 1.0).abs());
    }
    eprintln!("stroke times from outside: within {worst:.2e} relative of the cycler's");
    // docs/fmu.md quotes the measured agreement
    common::quotes::Page::read("docs/fmu.md").says("and retract times agree with the cycler's within", &[Some(worst)]);
}

#[test]
fn setting_an_input_to_its_value_changes_nothing_and_a_copy_goes_on_like_the_original() {
    let flat = meter_out_with_valve_input();
    let mut a = stepper(&flat, Drive::External);
    a.set_input(0, 1.0).unwrap();
    a.advance_to(0.2).unwrap();
    let mut b = a.clone();
    for k in 1..=300 {
        let t = 0.2 + k as f64 * 1e-3;
        a.advance_to(t).unwrap();
        b.set_input(0, 1.0).unwrap(); // the master sets every input at every step
        b.advance_to(t).unwrap();
    }
    assert_eq!(a.state(), b.state(), "the copy with the same input set again ends elsewhere");
    assert!(output(&mut a, "x") > 0.01, "the piston extends: x = {} m", output(&mut a, "x"));
    // a copy is independent: retracting one leaves the other extending
    let mut c = a.clone();
    c.set_input(0, 0.0).unwrap();
    c.advance_to(0.8).unwrap();
    a.advance_to(0.8).unwrap();
    let (xa, xc) = (output(&mut a, "x"), output(&mut c, "x"));
    assert!(xc < 1e-3 && xa > 0.1, "x: {xc} m retracted, {xa} m extending");
}

#[test]
fn a_changed_input_restarts_the_integration_and_an_impossible_one_is_an_error() {
    let text = std::fs::read_to_string(common::models_dir().join("meter_out.json")).unwrap();
    let mut netlist: serde_json::Value = serde_json::from_str(&text).unwrap();
    netlist["interface"]["inputs"] = json!({ "p_supply": { "parameter": "supply.p", "unit": "bar" } });
    let flat = common::flat_from_json(&netlist);
    let mut s = stepper(&flat, Drive::External);
    s.advance_to(0.5).unwrap();
    let x_low = output(&mut s, "x");
    // a supply pressure outside its range is refused and leaves the run as it was
    assert!(s.set_input(0, -1.0).is_err());
    s.set_input(0, 7e5).unwrap();
    s.advance_to(0.6).unwrap();
    let moved_fast = output(&mut s, "x") - x_low;
    let mut slow = stepper(&flat, Drive::External);
    slow.advance_to(0.6).unwrap();
    let moved_slow = output(&mut slow, "x") - x_low;
    assert!(moved_fast > moved_slow + 1e-3, "7 bar moves the piston faster than 4 bar: {moved_fast} against {moved_slow} m in 0.1 s");
    // a time going backwards does nothing; a non-finite one is refused
    s.advance_to(0.3).unwrap();
    assert_eq!(s.t(), 0.6);
    assert!(s.advance_to(f64::NAN).is_err());
}
