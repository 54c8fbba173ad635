//! Trim operating points (issue 25): an equilibrium that meets the
//! conditions a user states, here the paper's cylinder with both chambers
//! closed held with its piston at a stated position
//! (`pneumo linearize --at "piston.x=200 mm; F=0 N; head.p=4 bar"`).
//!
//! Closed form of the trimmed point: at rest the piston's force balance
//! A₁ p₁ = A₂ p₂ + A_rod p_atm + F (no friction at v = 0, sliding mode)
//! fixes the rod-side pressure, and each chamber's temperature is the wall's.

use graph::Drive;
use solve::linearize::trim::{self, Constraint};
use solve::linearize::{self, Friction};
use solve::Model;

mod common;

const FILE: &str = "examples/linearize/paper_cylinder_mid_stroke.json";

fn driven() -> Model {
    let flat = common::flat_from_model(FILE, &[]);
    Model::new(graph::build_with(&flat, Drive::External).unwrap_or_else(|e| panic!("build: {e}")))
}

fn constraint(model: &Model, name: &str, value: f64) -> Constraint {
    let (target, _) = trim::target(model, name).unwrap_or_else(|| panic!("{name}: no such variable"));
    Constraint { name: name.to_string(), target, value }
}

fn state(model: &Model, name: &str) -> usize {
    (0..model.n_states).find(|&i| model.state_name(i) == name).unwrap_or_else(|| panic!("no state {name}"))
}

fn trim_error(stated: &[(&str, f64)]) -> String {
    let mut model = driven();
    let guess = model.initial_state();
    let cs: Vec<Constraint> = stated.iter().map(|&(n, v)| constraint(&model, n, v)).collect();
    match trim::trim(&mut model, &guess, &cs, Friction::Auto) {
        Ok(op) => panic!("{stated:?}: a trim at {:?}", op.y),
        Err(e) => e.to_string(),
    }
}

#[test]
fn trimmed_point_is_an_equilibrium_with_the_piston_where_stated() {
    let mut model = driven();
    // start away from the answer: mid-stroke (225 mm), rod side at 4.3775 bar
    let guess = model.initial_state();
    let x = 0.2;
    let cs = vec![constraint(&model, "piston.x", x), constraint(&model, "F", 0.0), constraint(&model, "head.p", 4e5)];
    let op = trim::trim(&mut model, &guess, &cs, Friction::Auto).unwrap_or_else(|e| panic!("trim: {e}"));
    assert_eq!(op.kind, linearize::PointKind::Trim);
    let report = op.trim.as_ref().expect("a trim report");
    assert!(report.iterations >= 1, "the guess was not already the answer");
    assert!(report.residual < 1e-10, "residual {:e}", report.residual);
    assert!(report.untouched.is_empty(), "{:?}", report.untouched);
    assert_eq!(op.y[state(&model, "piston.x")], x);

    // the residual derivatives, evaluated afresh, relative to each state's size per second
    let f = linearize::jacobians::rates(&mut model, op.t, &op.y).unwrap();
    let scales = model.state_scales(&op.y);
    for i in 0..model.n_states {
        if model.state_name(i).contains('.') && scales[i] > 0.0 {
            let rel = f[i].abs() / scales[i].max(op.y[i].abs());
            assert!(rel < 1e-9, "d{}/dt = {:e} at the trim", model.state_name(i), f[i]);
        }
    }

    // the closed form: temperatures at the wall, the rod pressure from the force balance
    for t in ["head.T", "rod.T"] {
        assert!((op.y[state(&model, t)] - 292.0).abs() < 1e-9, "{t} = {}", op.y[state(&model, t)]);
    }
    let names = model.output_names();
    let col = |n: &str| names.iter().position(|c| c == n).unwrap_or_else(|| panic!("no column {n}"));
    let p = linearize::jacobians::recorded(&mut model, op.t, &op.y, &[col("head.p"), col("rod.p")]).unwrap();
    let a1 = std::f64::consts::PI / 4.0 * 0.045f64.powi(2);
    let a_rod = std::f64::consts::PI / 4.0 * 0.015f64.powi(2);
    let p_rod = (a1 * 4e5 - a_rod * 0.98e5) / (a1 - a_rod);
    assert!((p[0] - 4e5).abs() < 1e-6 * 4e5, "head.p = {} Pa", p[0]);
    assert!((p[1] - p_rod).abs() < 1e-6 * p_rod, "rod.p = {} Pa, force balance {p_rod} Pa", p[1]);

    // and the linear model about it has the piston where it was trimmed
    let lm = linearize::linearize(&mut model, &op, &linearize::Options::default()).unwrap_or_else(|e| panic!("linearize: {e}"));
    let k = lm.outputs.iter().position(|o| o.name == "x").expect("output x");
    assert!((lm.y0[k] - x).abs() < 1e-12, "y0 x = {}", lm.y0[k]);
    // in the mode the trim was solved in (v = 0: viscous friction only), so
    // that the point is an equilibrium of the linear model too
    assert!(lm.mechanics[0].description.contains("sliding about v = 0"), "{}", lm.mechanics[0].description);
    for (s, dx) in lm.states.iter().zip(&lm.dx0) {
        assert!(dx.abs() < 1e-9, "d{}/dt = {dx:e} in the linear model's mode", s.name);
    }
}

#[test]
fn a_trim_that_cannot_be_reached_names_the_stated_variable() {
    // beyond the 450 mm stroke the rod chamber has no volume
    let e = trim_error(&[("piston.x", 0.6), ("F", 0.0), ("head.p", 4e5)]);
    assert!(e.contains("piston.x = 0.6 m") && e.contains("cannot be evaluated"), "{e}");
    // a negative absolute pressure has no equilibrium
    let e = trim_error(&[("piston.x", 0.2), ("F", 0.0), ("head.p", -4e5)]);
    assert!(e.contains("no equilibrium found") && e.contains("head.p = -400000 Pa"), "{e}");
    // too few conditions: the free unknowns are named
    let e = trim_error(&[("piston.x", 0.2)]);
    assert!(e.contains("under-determined") && e.contains("head.m") && e.contains("rod.m") && e.contains("F"), "{e}");
}

/// `models/position_control.json` driven from outside: its zero-lapped
/// proportional valve starts at centre, where every opening's slope is zero
/// on one side (a kink). The trim must not count that kink as a free
/// direction ("under-determined ... valve.spool, u") nor stall on it: held at
/// mid-stroke with no load, it finds the valve command that balances the
/// piston (the rod side's smaller area needs a lower head pressure: u < 0).
#[test]
fn trim_from_a_spool_at_centre_finds_the_balancing_command() {
    let flat = common::flat_from_model("position_control.json", &["cyl.x0=100 mm"]);
    let mut model = Model::new(graph::build_with(&flat, Drive::External).unwrap_or_else(|e| panic!("build: {e}")));
    let guess = model.initial_state();
    assert_eq!(guess[state(&model, "valve.spool")], 0.0, "the guess sits on the kink");
    let cs = vec![constraint(&model, "cyl.piston.x", 0.1), constraint(&model, "F_load", 0.0)];
    let op = trim::trim(&mut model, &guess, &cs, Friction::Auto).unwrap_or_else(|e| panic!("trim: {e}"));
    let report = op.trim.as_ref().expect("a trim report");
    assert!(report.residual < 1e-10, "residual {:e}", report.residual);
    let u = report.solved.iter().find(|v| v.name == "u").expect("u solved").value;
    let spool = op.y[state(&model, "valve.spool")];
    assert!(u < 0.0 && u > -0.1, "u = {u}");
    assert!((spool - u).abs() < 1e-12, "the spool rests at the command: {spool} against {u}");
    let f = linearize::jacobians::rates(&mut model, op.t, &op.y).unwrap();
    let scales = model.state_scales(&op.y);
    for i in 0..model.n_states {
        let name = model.state_name(i);
        if name.starts_with("controller.") {
            continue; // driven from outside, the PID reaches no output
        }
        assert!((f[i] / scales[i].max(op.y[i].abs())).abs() < 1e-9, "d{name}/dt = {:e}", f[i]);
    }
}
