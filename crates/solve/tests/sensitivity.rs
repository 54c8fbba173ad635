//! Forward parameter sensitivities (`solve::simulate_with_sensitivities`)
//! checked against central differences of whole simulations at tight
//! tolerance (rtol 1e-9), and against a closed form where one exists:
//! (a) a smooth run — choked adiabatic discharge of a rigid tank, whose
//!     pressure has a closed form in the conductance C;
//! (b) the paper's meter-out circuit through its stick–slip transitions,
//!     end stops and valve switchings, sensitivity to the friction k0 and to
//!     the throttle's conductance;
//! (c) a cylinder that breaks away and runs into its end stop (a reset of the
//!     velocity), sensitivity to the inlet conductance.
//! The agreement measured is printed (`--nocapture`) and quoted in
//! docs/performance.md ("Parameter sensitivities").

mod common;

use common::{flat_from_json, flat_from_model};
use graph::FlatNetlist;
use serde_json::{json, Value};
use solve::{Model, Parameter, SimOptions, SimResult};

/// Relative perturbation of the parameter copies (the sensitivity's δ).
const DELTA: f64 = 1e-7;

fn tight(flat: &FlatNetlist) -> SimOptions {
    let mut opts = solve::options_from(&graph::build(flat).unwrap().simulation).unwrap();
    opts.rtol = 1e-9;
    opts.atol = 1e-9;
    // the method of a run with sensitivities (see solve::sensitivity), so
    // that the plain runs compared with it take the same steps
    opts.method = ode::Method::Ros34pw2;
    opts
}

fn model(flat: &FlatNetlist) -> Model {
    Model::new(graph::build(flat).unwrap_or_else(|e| panic!("build: {e}")))
}

fn run(flat: &FlatNetlist, opts: &SimOptions) -> SimResult {
    solve::simulate(&mut model(flat), opts).unwrap_or_else(|e| panic!("simulate: {e}"))
}

/// `channel` of a result at its grid times (None where undefined).
fn column(res: &SimResult, channel: &str) -> Vec<(f64, Option<f64>)> {
    let c = res.column(channel).unwrap_or_else(|| panic!("no column {channel}"));
    res.times.iter().zip(&res.rows).map(|(t, r)| (*t, r[c])).collect()
}

/// Value of a grid column at time t (the first row at that time).
fn at(col: &[(f64, Option<f64>)], t: f64) -> Option<f64> {
    col.iter().find(|(ti, _)| (ti - t).abs() < 1e-12).and_then(|(_, v)| *v)
}

/// Comparison of a sensitivity with a central difference of two runs at
/// θ(1 ± h): the largest difference on the common sample grid, relative to
/// the largest |sensitivity|, skipping samples within `guard` seconds of an
/// event of the base run (there a finite parameter change moves the event
/// past the sample, and the difference quotient measures the jump, not the
/// derivative).
struct Agreement {
    worst: f64,
    scale: f64,
    compared: usize,
}

fn compare(base: &SimResult, sens: &[Option<f64>], plus: &SimResult, minus: &SimResult, channel: &str, step: f64, guard: f64) -> Agreement {
    let (p, m) = (column(plus, channel), column(minus, channel));
    let events: Vec<f64> = base.events.iter().map(|e| e.t).collect();
    let (mut worst, mut scale, mut compared) = (0.0f64, 0.0f64, 0);
    for (row, &t) in base.times.iter().enumerate() {
        let Some(s) = sens[row] else { continue };
        scale = scale.max(s.abs());
        if events.iter().any(|&te| (t - te).abs() <= guard) {
            continue;
        }
        let (Some(vp), Some(vm)) = (at(&p, t), at(&m, t)) else { continue };
        let cd = (vp - vm) / (2.0 * step);
        worst = worst.max((cd - s).abs());
        compared += 1;
    }
    Agreement { worst, scale, compared }
}

/// Sensitivity of `channels` to the parameter set by `set(value)`, against
/// central differences with relative step `h`.
fn check(
    name: &str,
    build: &dyn Fn(f64) -> FlatNetlist,
    theta: f64,
    channels: &[&str],
    h: f64,
    guard: f64,
    tol: f64,
) -> (SimResult, solve::Sensitivities) {
    let flat = build(theta);
    let opts = tight(&flat);
    let delta = DELTA * theta;
    let params = vec![Parameter { name: name.into(), model: model(&build(theta + delta)), delta }];
    let (res, sens) = solve::simulate_with_sensitivities(&mut model(&flat), params, &opts).unwrap_or_else(|e| panic!("{e}"));
    // the run itself is the run without sensitivities, bit for bit
    let plain = run(&flat, &opts);
    assert_eq!(plain.times, res.times, "{name}: the grid changed");
    assert!(plain.rows == res.rows, "{name}: asking for sensitivities changed the run");
    let plus = run(&build(theta * (1.0 + h)), &opts);
    let minus = run(&build(theta * (1.0 - h)), &opts);
    for ch in channels {
        let s = sens.series(ch, name).unwrap();
        let a = compare(&res, &s, &plus, &minus, ch, theta * h, guard);
        eprintln!(
            "{name} → {ch}: max |dy/dθ| = {:.4e}, worst |sensitivity − central difference| = {:.3e} ({:.2e} of max) over {} samples",
            a.scale,
            a.worst,
            a.worst / a.scale,
            a.compared
        );
        assert!(a.compared > 20, "{name} → {ch}: only {} samples compared", a.compared);
        assert!(a.scale > 0.0, "{name} → {ch}: zero sensitivity");
        assert!(a.worst <= tol * a.scale, "{name} → {ch}: worst difference {:.3e} of the largest sensitivity", a.worst / a.scale);
    }
    (res, sens)
}

// ---------------------------------------------------------------------------
// (a) Choked adiabatic discharge: p(t) = p0 [1 + (γ−1)/(2γ) t/τ]^(−2γ/(γ−1)),
//     τ = V / (γ R C ρ_ref √(T_ref T0)), so with u = 1 + (γ−1)/(2γ) t/τ
//     ∂p/∂C = ∂p/∂τ · ∂τ/∂C = [p0 u^(−(3γ−1)/(γ−1)) t/τ²] · (−τ/C)
//            = −p0 u^(−(3γ−1)/(γ−1)) t/(τ C).
// ---------------------------------------------------------------------------

const T_REF: f64 = 293.15;
const RHO_REF: f64 = 1.185;

fn discharge(c: f64) -> FlatNetlist {
    flat_from_json(&json!({
        "name": "choked_discharge",
        "gas": { "model": "ideal", "species": "air" },
        "components": [
            { "id": "tank", "type": "chamber", "params": { "dead_volume": 1e-3, "tau_thermal": "inf" }, "init": { "p0": 6e5, "T0": 293.15 } },
            { "id": "orifice", "type": "conductance", "params": { "C": c, "b": 0.3, "T_ref": T_REF, "rho_ref": RHO_REF } },
            { "id": "atm", "type": "atmosphere", "params": { "p": 5e3, "T": 293.15 } }
        ],
        "connections": [["tank.port", "orifice.a"], ["orifice.b", "atm.port"]],
        "simulation": { "t_end": 0.5, "sample_interval": "5 ms" }
    }))
}

#[test]
fn a_smooth_discharge_sensitivity_to_conductance() {
    let c = 20.0 / 60.0 * 1e-3 / 1e5; // 20 L/min/bar
    let (res, sens) = check("orifice.C", &discharge, c, &["tank.p", "tank.T"], 1e-4, 0.0, 1e-5);
    // against the closed form while choked (the model itself is within 2e-3 of it, reference.rs (b))
    let (r, cp) = (287.0, 1004.5);
    let gamma = cp / (cp - r);
    let tau = 1e-3 / (gamma * r * c * RHO_REF * (T_REF * 293.15f64).sqrt());
    let s = sens.series("tank.p", "orifice.C").unwrap();
    let mut worst = 0.0f64;
    for (row, &t) in res.times.iter().enumerate() {
        let u = 1.0 + (gamma - 1.0) / (2.0 * gamma) * t / tau;
        let p = 6e5 * u.powf(-2.0 * gamma / (gamma - 1.0));
        if p * 0.3 < 5e3 * 1.05 {
            break; // no longer choked
        }
        let exact = -6e5 * u.powf(-(3.0 * gamma - 1.0) / (gamma - 1.0)) * t / (tau * c);
        if let Some(v) = s[row] {
            worst = worst.max((v - exact).abs() / (6e5 * tau / c * 0.3).abs());
        }
    }
    eprintln!("(a) ∂p/∂C against the closed form: worst {worst:.2e} of the scale p0·t/(τC) at t = 0.3τ");
    assert!(worst < 5e-4, "{worst}");
}

// ---------------------------------------------------------------------------
// (b) meter-out through stick–slip, end stops and valve switching
// ---------------------------------------------------------------------------

fn meter_out(set: &'static str, unit: &'static str) -> impl Fn(f64) -> FlatNetlist {
    move |v: f64| flat_from_model("meter_out.json", &[&format!("{set}={v:.17e} {unit}"), "simulation.cycles=1"])
}

#[test]
fn b_meter_out_sensitivity_to_friction_through_stick_slip() {
    let (res, _) = check("friction.k0", &meter_out("friction.k0", "N"), 10.0, &["piston.x", "head.p"], 1e-3, 5e-3, 1e-2);
    assert!(res.events.iter().any(|e| e.what.contains("sliding")), "no stick–slip transition: {:?}", res.events);
    assert!(res.events.iter().any(|e| e.what.contains("stop")), "no end stop: {:?}", res.events);
}

#[test]
fn b_meter_out_sensitivity_to_throttle_conductance() {
    check("flow_control.C", &meter_out("flow_control.C", "L/min/bar"), 13.2, &["piston.x", "rod.p"], 1e-4, 5e-3, 1e-2);
}

// ---------------------------------------------------------------------------
// (c) breakaway and end stop
// ---------------------------------------------------------------------------

fn end_stop(c_inlet: f64) -> FlatNetlist {
    let netlist: Value = json!({
        "name": "end_stop",
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": 3e5, "T": 293.15 } },
            { "id": "inlet", "type": "conductance", "params": { "C": c_inlet, "b": 0.3 } },
            { "id": "head", "type": "chamber",
              "params": { "dead_volume": "50 cm3", "area": 1e-3, "T_wall": 293.15 },
              "init": { "p0": "1 bar", "T0": 293.15 } },
            { "id": "piston", "type": "piston", "params": { "mass": "1 kg", "stroke": "100 mm" }, "init": { "x0": 0.05 } },
            { "id": "friction", "type": "friction", "params": { "k0": 150 } }
        ],
        "connections": [
            ["supply.port", "inlet.a"], ["inlet.b", "head.port"],
            ["head.piston", "piston.rod"], ["friction.rod", "piston.rod"],
            { "from": "head.p", "to": "friction.p1" },
            { "from": "head.p", "to": "friction.p2" }
        ],
        "simulation": { "t_end": 0.6, "sample_interval": "2 ms" }
    });
    flat_from_json(&netlist)
}

#[test]
fn c_breakaway_and_end_stop_sensitivity_to_inlet_conductance() {
    let c = 5.0 / 60.0 * 1e-3 / 1e5; // 5 L/min/bar
    let (res, sens) = check("inlet.C", &end_stop, c, &["piston.x", "piston.v", "head.p"], 1e-4, 5e-3, 1e-5);
    let stop = res.events.iter().find(|e| e.what.contains("piston") && e.what.contains("upper stop"));
    assert!(stop.is_some(), "no end stop: {:?}", res.events);
    // at the stop the position no longer depends on C
    let x = sens.series("piston.x", "inlet.C").unwrap();
    let last = x.last().copied().flatten().unwrap();
    assert!(last.abs() < 1e-6 * 0.1 / c, "∂x/∂C at the stop = {last:e}");
}
