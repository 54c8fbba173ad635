//! Linearisation against closed forms (issue 25): a cylinder with both
//! chambers closed at mid-stroke is a mass between two gas springs.
//!
//! Closed form (the pneumatic spring, e.g. Beater, "Pneumatic Drives" §6): a
//! closed chamber of volume V = V₀ + A·x holding its gas compresses
//! polytropically, dp/dx = −n p A / V, so the piston of mass M sees the
//! stiffness k = n (A₁² p₁/V₁ + A₂² p₂/V₂) and ω² = k / M, with n = γ for an
//! adiabatic wall (τ_T → ∞) and n = 1 for an isothermal one (τ_T → 0). A
//! viscous friction slope c adds ζ = c / (2 M ω) (τ_T → ∞: the mass–spring–
//! damper is then the whole dynamics; the gas masses and the entropies are
//! integrators that do not feed back).
//!
//! The second test checks the linear model in time: its step response to a
//! small force step against the nonlinear simulation, the difference
//! shrinking as the amplitude squared.

use graph::Drive;
use serde_json::json;
use solve::linearize::{self, OperatingPoint, Options, Outputs, PointKind};
use solve::Model;

mod common;

const BORE: f64 = 0.045;
const ROD: f64 = 0.015;
const STROKE: f64 = 0.45;
const DEAD: f64 = 20e-6;
const MASS: f64 = 1.0;
const P_HEAD: f64 = 4e5;
const P_ROD: f64 = 7e5;
const P_ATM: f64 = 1e5;
const X_MID: f64 = 0.225;

fn areas() -> (f64, f64, f64) {
    let a1 = std::f64::consts::PI / 4.0 * BORE * BORE;
    let a_rod = std::f64::consts::PI / 4.0 * ROD * ROD;
    (a1, a1 - a_rod, a_rod)
}

/// The force that holds the piston where it is with the chambers at their
/// start pressures: F = −(A₁ p₁ − A₂ p₂ − A_rod p_atm).
fn holding_force() -> f64 {
    let (a1, a2, a_rod) = areas();
    -(a1 * P_HEAD - a2 * P_ROD - a_rod * P_ATM)
}

/// Both chambers closed (a zero mass-flow source on each port), the piston at
/// mid-stroke, its load an interface input `F`.
fn closed_cylinder(tau: &str, friction: bool) -> graph::FlatNetlist {
    let mut components = vec![
        json!({ "id": "plug_head", "type": "mass_flow_source", "params": { "mdot": "0 g/s", "T": "293.15 K" } }),
        json!({ "id": "plug_rod", "type": "mass_flow_source", "params": { "mdot": "0 g/s", "T": "293.15 K" } }),
        json!({ "id": "head", "type": "chamber",
                "params": { "dead_volume": format!("{} cm3", DEAD * 1e6), "bore": "45 mm", "orientation": "extend",
                            "tau_thermal": tau, "T_wall": "293.15 K", "p0": "4 bar", "T0": "293.15 K" } }),
        json!({ "id": "rod", "type": "chamber",
                "params": { "dead_volume": format!("{} cm3", DEAD * 1e6), "bore": "45 mm", "rod_diameter": "15 mm",
                            "orientation": "retract", "length_at_zero": "450 mm",
                            "tau_thermal": tau, "T_wall": "293.15 K", "p0": "7 bar", "T0": "293.15 K" } }),
        json!({ "id": "piston", "type": "piston",
                "params": { "mass": "1 kg", "stroke": "450 mm", "rod_diameter": "15 mm", "p_atm": "1 bar",
                            "x0": "225 mm", "external_force": format!("{} N", holding_force()) } }),
    ];
    let mut connections = vec![
        json!(["plug_head.port", "head.port"]),
        json!(["plug_rod.port", "rod.port"]),
        json!(["head.piston", "piston.rod"]),
        json!(["rod.piston", "piston.rod"]),
    ];
    if friction {
        components.push(json!({ "id": "friction", "type": "friction",
            "params": { "k0": "10 N", "k1": "2e-5 N/Pa", "k2": "50 N s/m", "k3": "2e-4 N s/(m Pa)", "k4": 0.9 } }));
        connections.push(json!(["friction.rod", "piston.rod"]));
        connections.push(json!({ "from": "head.p", "to": "friction.p1" }));
        connections.push(json!({ "from": "rod.p", "to": "friction.p2" }));
    }
    common::flat_from_json(&json!({
        "name": "closed_cylinder",
        "gas": { "model": "ideal", "species": "air" },
        "components": components,
        "connections": connections,
        "interface": {
            "inputs": { "F": { "parameter": "piston.external_force", "unit": "N" } },
            "outputs": { "x": { "from": "piston.x", "unit": "mm" }, "p_head": { "from": "head.p", "unit": "bar" },
                         "a": { "from": "piston.a", "unit": "m/s2" } }
        },
        "simulation": { "t_end": "0.3 s", "rtol": 1e-10, "atol": 1e-10, "sample_interval": "1 ms", "max_step": "1 ms" }
    }))
}

fn driven(flat: &graph::FlatNetlist) -> Model {
    Model::new(graph::build_with(flat, Drive::External).unwrap_or_else(|e| panic!("build: {e}")))
}

/// The linear model at the start state, every state kept.
fn linear_at_start(model: &mut Model) -> linearize::LinearModel {
    let y = model.initial_state();
    let op = OperatingPoint { t: 0.0, y, kind: PointKind::Rest, trim: None };
    let opts = Options { keep_all_states: true, outputs: Outputs::Interface, ..Options::default() };
    let lm = linearize::linearize(model, &op, &opts).unwrap_or_else(|e| panic!("linearize: {e}"));
    // the closed-form checks below hold with the exact state Jacobian
    assert_eq!(lm.method, linearize::jacobians::Method::Exact);
    assert!(lm.finite_difference_blocks.is_empty(), "{:?}", lm.finite_difference_blocks);
    lm
}

/// The oscillating mode (the one complex pair).
fn oscillation(lm: &linearize::LinearModel) -> linear::modal::Mode {
    let modes = linear::modal::modes(&lm.a).unwrap();
    let pairs: Vec<_> = modes.iter().filter(|m| m.pair).collect();
    assert_eq!(pairs.len(), 1, "one oscillating mode expected: {modes:?}");
    pairs[0].clone()
}

fn output(lm: &linearize::LinearModel, name: &str) -> usize {
    lm.outputs.iter().position(|o| o.name == name).unwrap_or_else(|| panic!("no output {name}: {:?}", lm.outputs))
}

/// ω² = (n/M)(A₁² p₁/V₁ + A₂² p₂/V₂) at mid-stroke.
fn closed_form_omega(n: f64) -> f64 {
    let (a1, a2, _) = areas();
    let (v1, v2) = (DEAD + a1 * X_MID, DEAD + a2 * (STROKE - X_MID));
    (n / MASS * (a1 * a1 * P_HEAD / v1 + a2 * a2 * P_ROD / v2)).sqrt()
}

/// docs/linearize.md's section that quotes these tests.
fn closed_forms_page() -> common::quotes::Page {
    common::quotes::Page::read("docs/linearize.md").section("## Closed-form checks")
}

fn gamma(model: &Model) -> f64 {
    let rho = model.circuit.gas.density(P_HEAD, 293.15);
    model.circuit.gas.gamma(rho, 293.15)
}

#[test]
fn adiabatic_closed_cylinder_oscillates_at_the_pneumatic_spring_frequency() {
    let mut model = driven(&closed_cylinder("inf", false));
    let lm = linear_at_start(&mut model);
    assert_eq!(lm.states.len(), 6, "{:?}", lm.states);
    assert!(lm.dx0.iter().all(|d| d.abs() < 1e-9), "not an equilibrium: {:?}", lm.dx0);
    let mode = oscillation(&lm);
    let expected = closed_form_omega(gamma(&model));
    let rel = (mode.natural_frequency - expected).abs() / expected;
    eprintln!("adiabatic: ω = {} rad/s, closed form {expected} rad/s, relative difference {rel:.2e}", mode.natural_frequency);
    // docs/linearize.md's table (its last column, a rounding-level difference, is a measurement)
    closed_forms_page().says("| τ_T = ∞ (n = γ) | ω =", &[Some(mode.natural_frequency), Some(expected)]);
    assert!(rel < 1e-6, "ω = {} vs {expected} (rel {rel:e})", mode.natural_frequency);
    assert!(mode.damping.abs() < 1e-6, "no friction, no heat exchange: ζ = {}", mode.damping);
    // B: the load enters the acceleration only, as 1/M
    let v = lm.states.iter().position(|s| s.name == "piston.v").unwrap();
    assert!((lm.b[(v, 0)] - 1.0 / MASS).abs() < 1e-8, "∂v̇/∂F = {}", lm.b[(v, 0)]);
    // C: x in SI (m); p_head = m R T / V with m and T states of their own: ∂p/∂x = −p A / V
    let x = lm.states.iter().position(|s| s.name == "piston.x").unwrap();
    let (out_x, out_p) = (output(&lm, "x"), output(&lm, "p_head"));
    assert!((lm.c[(out_x, x)] - 1.0).abs() < 1e-8 && lm.outputs[out_x].unit == "m", "{}", lm.c[(out_x, x)]);
    let (a1, _, _) = areas();
    let dp_dx = -P_HEAD * a1 / (DEAD + a1 * X_MID);
    assert!((lm.c[(out_p, x)] / dp_dx - 1.0).abs() < 1e-8, "∂p/∂x = {} vs {dp_dx}", lm.c[(out_p, x)]);
    assert_eq!(lm.outputs[out_p].unit, "Pa");
}

#[test]
fn isothermal_closed_cylinder_oscillates_at_the_isothermal_spring_frequency() {
    // τ_T = 1e-7 s: the wall holds the gas temperature; the frequency differs
    // from the isothermal closed form by O((ω τ_T)²) ≈ 1e-10.
    let mut model = driven(&closed_cylinder("1e-7 s", false));
    let lm = linear_at_start(&mut model);
    let mode = oscillation(&lm);
    let expected = closed_form_omega(1.0);
    let rel = (mode.natural_frequency - expected).abs() / expected;
    eprintln!("isothermal: ω = {} rad/s, closed form {expected} rad/s, relative difference {rel:.2e}", mode.natural_frequency);
    closed_forms_page().says("| τ_T = 1e-7 s (n = 1) | ω =", &[Some(mode.natural_frequency), Some(expected)]);
    assert!(rel < 1e-6, "ω = {} vs {expected} (rel {rel:e})", mode.natural_frequency);
}

#[test]
fn viscous_friction_damps_as_a_mass_spring_damper() {
    // About v = 0 the Coulomb level drops out; c = k2 + k3 (p1 − k4 p2), clipped at 0.
    let mut model = driven(&closed_cylinder("inf", true));
    let lm = linear_at_start(&mut model);
    let mode = oscillation(&lm);
    let c = (50.0 + 2e-4 * (P_HEAD - 0.9 * P_ROD)).max(0.0);
    assert!(c > 0.0);
    let omega = closed_form_omega(gamma(&model));
    let zeta = c / (2.0 * MASS * omega);
    eprintln!("damping: ζ = {}, predicted {zeta}; ω = {}, predicted {omega}", mode.damping, mode.natural_frequency);
    closed_forms_page().says("k4 = 0.9 | ζ =", &[Some(mode.damping), None, Some(zeta)]);
    assert!((mode.damping - zeta).abs() < 1e-6 * zeta.max(1e-3), "ζ = {} vs {zeta}", mode.damping);
    assert!((mode.natural_frequency - omega).abs() < 1e-6 * omega);
    assert!(lm.mechanics[0].description.contains("viscous"), "{}", lm.mechanics[0].description);
}

/// Largest |δx_linear − δx_nonlinear| over 0.3 s after a load step of `amplitude` N, and the largest |δx|.
fn step_error(flat: &graph::FlatNetlist, amplitude: f64) -> (f64, f64) {
    let circuit = graph::build_with(flat, Drive::External).unwrap();
    let opts = solve::options_from(&circuit.simulation).unwrap();
    let run = |delta: f64| {
        let mut m = driven(flat);
        let u0 = m.input_value(0);
        m.set_input(0, u0 + delta).unwrap();
        let r = solve::simulate(&mut m, &opts).unwrap_or_else(|e| panic!("simulate: {e}"));
        common::series(&r, "piston.x")
    };
    let (base, stepped) = (run(0.0), run(amplitude));
    let mut model = driven(flat);
    let lm = linear_at_start(&mut model);
    let h = 1e-3;
    let samples = 301;
    let lin = linear::time::step(&lm.a, &lm.b, &lm.c, &lm.d, 0, h, samples).unwrap();
    let x = output(&lm, "x");
    let (mut err, mut size) = (0.0f64, 0.0f64);
    for (k, row) in lin.iter().enumerate() {
        let t = k as f64 * h;
        let nonlinear = common::at(&stepped, t) - common::at(&base, t);
        err = err.max((amplitude * row[x] - nonlinear).abs());
        size = size.max(nonlinear.abs());
    }
    (err, size)
}

#[test]
fn step_response_matches_the_nonlinear_model_to_second_order_in_the_amplitude() {
    // τ_T = 20 ms: the heat exchange damps the oscillation (thermal damping).
    let flat = closed_cylinder("20 ms", false);
    let (e1, s1) = step_error(&flat, 10.0);
    let (e2, s2) = step_error(&flat, 5.0);
    eprintln!("step 10 N: |δx| ≤ {s1:.3e} m, error {e1:.3e} m; step 5 N: |δx| ≤ {s2:.3e} m, error {e2:.3e} m; ratio {:.3}", e1 / e2);
    // "over 0.3 s: a 10 N load step moves the piston … mm and the largest difference is … m;
    // a 5 N step, … mm and … m. Halving the amplitude divides the difference by …"
    let quoted = [None, Some(s1 * 1e3), Some(e1), None, Some(s2 * 1e3), Some(e2), Some(e1 / e2)];
    closed_forms_page().says("(rtol = atol = 1e-10) over 0.3 s:", &quoted);
    assert!(s1 > 1e-3, "the step moved the piston by only {s1} m");
    assert!(e1 < 0.02 * s1, "the linear model is off by {e1} m of {s1} m");
    let ratio = e1 / e2;
    assert!((3.6..4.4).contains(&ratio), "halving the amplitude divided the error by {ratio}, not ~4");
}

/// The exact state Jacobian behind `linearize` agrees with central
/// differences of the whole model, on every shipped model with an interface
/// section, at points in mid-run (the modes held). Entries are compared
/// scaled by the states' typical sizes (Aᵢⱼ·sⱼ/sᵢ, a rate per relative
/// change), relative to the row's largest scaled entry: central differences
/// are good to ~1e-8 there (see `jacobians`), so a wrong partial derivative
/// shows far above 1e-6. A column whose forward and backward differences
/// disagree by more than 1e-4 and stay apart at a tenth of the step (a kink:
/// a spool at its end of travel) is not smooth there; its exact column must
/// then match one of the two one-sided slopes instead. Where they part by
/// O(h) only (a large curvature) or the second derivative has a kink within
/// the step, the central difference is off by O(h) or O(h²); the comparison
/// then takes the best of the steps h, h/10, h/100 — the exact column is
/// their limit. Measured: mid_stop_5_3 at 0.39 s, ∂/∂cyl.head.T 7.5e-6 at h,
/// 7.5e-7 at h/10, 7.6e-8 at h/100; at 0.51 s, ∂ṁ_head/∂x (the head chamber
/// at r = p_A/p_P ≈ 0.994, where the ISO 6358 ω'' grows as (1 − r)^(−3/2))
/// forward/backward 19.134/19.920 at h = 1.2 µm, 19.4723/19.5507 at h/10,
/// 19.50746/19.51530 at h/100, exact 19.511381 (docs/linearize.md).
/// docs/linearize.md's section on how the derivatives are formed, whose
/// checks quote the two Jacobian tests below.
fn derivatives_page() -> common::quotes::Page {
    common::quotes::Page::read("docs/linearize.md").section("## How the derivatives are formed")
}

/// docs/linearize.md's table of one-sided quotients at mid_stop_5_3's
/// t = 0.51 s: the column of `cyl.piston.x`, row `cyl.head.m`, forward,
/// backward and central with the steps h, h/10, h/100, h/1000, against the
/// exact entry; and the prose that reads it (the gaps, the central errors).
fn quotient_table_is_what_the_model_gives(model: &mut Model, t: f64, y: &[f64], exact: f64) {
    let n = model.n_states;
    let (i, j) = ["cyl.head.m", "cyl.piston.x"].map(|name| (0..n).find(|&k| model.state_name(k) == name).expect(name)).into();
    let scales = model.state_scales(y);
    let h = 6e-6 * y[j].abs().max(scales[j]);
    let f0 = linearize::jacobians::rates(model, t, y).unwrap()[i];
    let mut at = |dx: f64| {
        let mut yp = y.to_vec();
        yp[j] += dx;
        linearize::jacobians::rates(model, t, &yp).unwrap()[i]
    };
    let page = common::quotes::Page::read("docs/linearize.md").section("**Resolved: mid_stop_5_3 at t = 0.51 s**");
    page.says("| step | forward | backward | central | |---|---|---|---| | h =", &[Some(h * 1e6)]);
    let mut gaps = Vec::new();
    let mut central_errors = Vec::new();
    for (k, first) in ["h = 1.2 µm", "h/10", "h/100", "h/1000"].into_iter().enumerate() {
        let hk = h / 10f64.powi(k as i32);
        let (forward, backward) = ((at(hk) - f0) / hk, (f0 - at(-hk)) / hk);
        let central = (forward + backward) / 2.0;
        eprintln!("mid_stop_5_3 at {t} s, ∂ṁ_head/∂x with step {hk:e}: forward {forward}, backward {backward}, central {central}");
        let rows = page.rows(first);
        assert_eq!(rows.len(), 1, "docs/linearize.md: one row {first:?}");
        page.row_says(first, &rows[0], &[Some(forward), Some(backward), Some(central)]);
        // the table is about its digits: each to half a unit of its last digit
        for (cell, value) in rows[0].iter().zip([forward, backward, central]) {
            let (written, word) = cell.as_ref().expect("a number");
            assert!(
                (written - value).abs() <= common::numbers::half_ulp(word),
                "docs/linearize.md is stale: the row {first:?} says {word}, the model gives {value:.7}"
            );
        }
        gaps.push(Some(backward - forward));
        central_errors.push(Some((central - exact).abs()));
    }
    let exact_row = page.rows("exact");
    let (written, word) = exact_row[0][2].as_ref().expect("the exact entry");
    assert!(
        (written - exact).abs() <= common::numbers::half_ulp(word),
        "docs/linearize.md is stale: the exact entry is {exact:.7}, the page says {word}"
    );
    page.says("the exact ∂ṁ_head/∂x,", &[Some(exact)]);
    // "10 ms after the spool opened P→A (s = 0.865) the piston is 0.13 mm off its lower stop"
    let spool = (0..n).find(|&k| model.state_name(k) == "valve.spool").expect("the spool's state");
    page.says("10 ms after the spool opened P→A (s =", &[Some(y[spool]), Some(y[j] * 1e3)]);
    page.says("Forward and backward part by O(h) (", &gaps[..3]);
    page.says("converges to the exact value as h² (", &central_errors[..3]);
}

#[test]
fn exact_state_jacobian_agrees_with_central_differences_on_the_interface_models() {
    let mut smooth_columns = 0;
    // the worst smooth column of each case, and the curved columns' spreads at h and h/10
    let mut worsts = Vec::new();
    let mut meter_out_curvature = None;
    for (file, fraction) in [
        ("meter_out.json", 0.2),
        ("mid_stop_5_3.json", 0.13),
        // t = 0.51 s: 10 ms after the spool opened P→A, the piston 0.13 mm off
        // its stop, the head at r = p_A/p_P ≈ 0.994 (curvature, not a kink)
        ("mid_stop_5_3.json", 0.17),
        ("position_control.json", 0.3),
        ("sequence_ab.json", 0.2),
        ("examples/linearize/paper_cylinder_mid_stroke.json", 0.5),
    ] {
        let flat = common::flat_from_model(file, &[]);
        let (standalone, opts) = common::model_of(&flat);
        let mut model = driven(&flat);
        let t = fraction * opts.t_end;
        let op = linearize::point::at_time(standalone, &mut model, &opts, t).unwrap_or_else(|e| panic!("{file} at {t} s: {e}"));
        let options = Options { keep_all_states: true, ..Options::default() };
        let lm = linearize::linearize(&mut model, &op, &options).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(lm.method, linearize::jacobians::Method::Exact, "{file}");
        assert!(lm.finite_difference_blocks.is_empty(), "{file}: {:?}", lm.finite_difference_blocks);
        let n = model.n_states;
        let all: Vec<usize> = (0..n).collect();
        let fd = linearize::jacobians::central_differences(&mut model, op.t, &op.y, &all, &[]).unwrap();
        let kept: Vec<usize> = lm.states.iter().map(|s| (0..n).find(|&i| model.state_name(i) == s.name).unwrap()).collect();
        let scales = model.state_scales(&op.y);
        let scaled = |v: f64, i: usize, j: usize| v * scales[j] / scales[i];
        let row_max: Vec<f64> = kept.iter().map(|&i| kept.iter().map(|&j| scaled(fd.a[(i, j)], i, j).abs()).fold(0.0, f64::max)).collect();
        let f0 = linearize::jacobians::rates(&mut model, op.t, &op.y).unwrap();
        let (mut worst, mut kinks, mut curved) = ((0.0_f64, String::new()), Vec::new(), Vec::new());
        for (c, &j) in kept.iter().enumerate() {
            let h = 6e-6 * op.y[j].abs().max(scales[j]);
            // forward and backward quotients of column j with step hk
            let mut one_sided = |hk: f64| {
                let mut yp = op.y.clone();
                yp[j] += hk;
                let f_plus = linearize::jacobians::rates(&mut model, op.t, &yp).unwrap();
                yp[j] = op.y[j] - hk;
                let f_minus = linearize::jacobians::rates(&mut model, op.t, &yp).unwrap();
                let forward: Vec<f64> = (0..n).map(|i| (f_plus[i] - f0[i]) / hk).collect();
                let backward: Vec<f64> = (0..n).map(|i| (f0[i] - f_minus[i]) / hk).collect();
                (forward, backward)
            };
            let gap = |a: &dyn Fn(usize) -> f64, b: &dyn Fn(usize) -> f64| {
                kept.iter()
                    .enumerate()
                    .filter(|&(r, _)| row_max[r] > 0.0)
                    .map(|(r, &i)| (scaled(a(i) - b(i), i, j) / row_max[r]).abs())
                    .fold(0.0, f64::max)
            };
            let exact = |i: usize| lm.a[(kept.iter().position(|&k| k == i).unwrap(), c)];
            let steps = [h, h / 10.0, h / 100.0];
            let quotients: Vec<(Vec<f64>, Vec<f64>)> = steps.iter().map(|&hk| one_sided(hk)).collect();
            let spread: Vec<f64> = quotients.iter().map(|(fw, bw)| gap(&|i| fw[i], &|i| bw[i])).collect();
            // a kink: forward and backward slopes differ and stay apart as the
            // step shrinks; a large curvature (an ISO 6358 flow near r = 1,
            // where ω'' grows as (1 − r)^(−3/2)) also parts them at h, but by
            // O(h): a tenth of the step then brings them ten times closer
            if spread[0] > 1e-4 && spread[1] > 0.3 * spread[0] {
                let (fw, bw) = &quotients[1];
                let nearest = gap(&exact, &|i| fw[i]).min(gap(&exact, &|i| bw[i]));
                assert!(
                    nearest < 1e-4,
                    "{file}: the column of {} is at a kink and the exact one matches neither side ({nearest:e})",
                    model.state_name(j)
                );
                kinks.push(model.state_name(j));
                continue;
            }
            if spread[0] > 1e-4 {
                curved.push((model.state_name(j), spread[0], spread[1]));
                if file == "meter_out.json" && model.state_name(j) == "piston.x" {
                    meter_out_curvature = Some((spread[0], spread[1]));
                }
            }
            smooth_columns += 1;
            // the central differences' O(h²) error (and, at a kink of the
            // second derivative within the step, O(h)) shrinks with the step:
            // the exact column is their limit
            let e = quotients
                .iter()
                .map(|(fw, bw)| gap(&exact, &|i| (fw[i] + bw[i]) / 2.0))
                .chain(std::iter::once(gap(&exact, &|i| fd.a[(i, j)])))
                .fold(f64::INFINITY, f64::min);
            if e > worst.0 {
                worst = (e, model.state_name(j));
            }
        }
        eprintln!(
            "{file} at t = {} s ({} states; kinks at {kinks:?}; curved (column, spread at h, at h/10): {curved:?}): worst smooth column {} at {:.2e}",
            op.t,
            kept.len(),
            worst.1,
            worst.0
        );
        assert!(worst.0 < 1e-6, "{file}: the column of {} differs by {:e}", worst.1, worst.0);
        worsts.push(Some(worst.0));
        if file == "mid_stop_5_3.json" {
            worsts.push(Some(op.t));
        }
        if file == "mid_stop_5_3.json" && fraction == 0.17 {
            let c = kept.iter().position(|&k| model.state_name(k) == "cyl.piston.x").expect("the piston's column");
            let r = kept.iter().position(|&k| model.state_name(k) == "cyl.head.m").expect("the head's mass row");
            quotient_table_is_what_the_model_gives(&mut model, op.t, &op.y, lm.a[(r, c)]);
        }
    }
    assert!(smooth_columns >= 25, "{smooth_columns} smooth columns checked");
    // "measured worst columns: meter_out 1.4e-10, position_control 5.6e-12, sequence_ab 7.5e-11,
    // paper_cylinder_mid_stroke 1.6e-12, mid_stop_5_3 7.6e-8 at 0.39 s and 7.9e-8 at 0.51 s"
    // (the cases above in the order meter_out, mid_stop 0.39 s, mid_stop 0.51 s,
    // position_control, sequence_ab, the paper's cylinder; the first four are rounding level,
    // deterministic for one build of the code)
    let [meter, mid_a, t_a, mid_b, t_b, position, sequence, paper] = worsts[..] else { panic!("{worsts:?}") };
    let page = derivatives_page();
    page.says("measured worst columns: meter_out", &[meter, position, sequence, paper, mid_a, t_a, mid_b, t_b]);
    // "(meter_out's `piston.x` column, gap 1.6e-4 at h, 1.6e-5 at h/10, is a curvature too)"
    let (at_h, at_tenth) = meter_out_curvature.expect("meter_out's piston.x column is curved at h");
    common::quotes::Page::read("docs/linearize.md").says("(meter_out's `piston.x` column, gap", &[Some(at_h), Some(at_tenth)]);
}

/// A supply feeding a tank through two restrictions in series, a
/// mass-flow source on the junction node between them: the supply's pressure
/// and temperature and the source's flow and temperature are interface inputs, so the
/// inputs act through an effort (the supply) and a flow into a junction
/// solve (its implicit differentiation), and the restriction's recorded flow
/// feeds through (D ≠ 0).
fn fed_tank() -> graph::FlatNetlist {
    common::flat_from_json(&json!({
        "name": "fed_tank",
        "gas": { "model": "ideal", "species": "air" },
        "components": [
            { "id": "supply", "type": "pressure_source", "params": { "p": "6 bar" } },
            { "id": "c1", "type": "conductance", "params": { "C": "2 L/min/bar", "b": 0.3 } },
            { "id": "c2", "type": "conductance", "params": { "C": "1.5 L/min/bar", "b": 0.25 } },
            { "id": "feed", "type": "mass_flow_source", "params": { "mdot": "0.02 g/s", "T": "310 K" } },
            { "id": "tank", "type": "chamber", "params": { "dead_volume": "50 cm3", "tau_thermal": "1 s", "p0": "1 bar" } }
        ],
        "connections": [["supply.port", "c1.a"], ["c1.b", "c2.a"], ["feed.port", "c2.a"], ["c2.b", "tank.port"]],
        "interface": {
            "inputs": {
                "p_s": { "parameter": "supply.p", "unit": "bar" },
                "T_s": { "parameter": "supply.T", "unit": "K" },
                "q": { "parameter": "feed.mdot", "unit": "g/s" },
                "T_feed": { "parameter": "feed.T", "unit": "K" }
            },
            "outputs": {
                "p": { "from": "tank.p", "unit": "bar" },
                "T": { "from": "tank.T", "unit": "K" },
                "rho": { "from": "tank.rho", "unit": "kg/m3" },
                "mdot": { "from": "c2.mdot", "unit": "g/s" }
            }
        },
        "simulation": { "t_end": "0.5 s", "sample_interval": "1 ms" }
    }))
}

/// The largest difference between `exact` and `fd` (rows × columns), each
/// entry scaled by its column's size and taken relative to the largest
/// scaled entry of its row over `[fd | fd_other]` (the row's other matrix:
/// A beside B, C beside D); rows with nothing in them are compared absolutely.
fn scaled_gap(exact: &linear::Matrix, fd: &linear::Matrix, col_scale: &[f64], row_max: &[f64]) -> f64 {
    let mut worst = 0.0_f64;
    for i in 0..fd.rows() {
        for (j, &s) in col_scale.iter().enumerate() {
            let gap = ((exact[(i, j)] - fd[(i, j)]) * s).abs();
            worst = worst.max(if row_max[i] > 0.0 { gap / row_max[i] } else { gap });
        }
    }
    worst
}

/// Exact B, C, D — the interface inputs seeded through their blocks' live
/// partials, the outputs read from their signals' gradients, with
/// implicit differentiation through the junction solves — agree with
/// central differences of the whole model, on the closed-chamber cylinder,
/// position_control (at a trim and in mid-run) and the fed tank. Entries are
/// scaled by their column's size (a state's typical size, max(|u|, one of its unit) for
/// an input) relative to the row's largest scaled entry, as for A
/// (central differences are good to ~1e-8 there). The fallbacks are named:
/// position_control's spool and the fed tank's density and flow are recorded
/// values without partials (their blocks' records differenced alone and
/// chained exactly); the closed cylinder's piston acceleration,
/// recorded by the block whose live parameter (the load) is an input, is
/// differenced whole.
#[test]
fn exact_input_and_output_jacobians_agree_with_central_differences() {
    enum At {
        Rest,
        /// A fraction of the run.
        Time(f64),
        /// A trim holding these variables.
        Trim(&'static [(&'static str, f64)]),
    }
    let closed = closed_cylinder("20 ms", true);
    let position = common::flat_from_model("position_control.json", &[]);
    // the trim of docs/position_control_tuning.md: the piston sliding about v = 0, both inputs acting
    let position_mid = common::flat_from_model("position_control.json", &["cyl.x0=100 mm"]);
    let tank = fed_tank();
    // (inputs by whole-model differences, outputs likewise, outputs whose block's record is differenced alone)
    type Fallbacks<'a> = (&'a [&'a str], &'a [&'a str], &'a [&'a str]);
    let cases: [(&str, &graph::FlatNetlist, At, Fallbacks); 5] = [
        // the piston's recorded acceleration: its block's live parameter is the input F
        ("closed cylinder at rest", &closed, At::Rest, (&[], &["a"], &[])),
        (
            "position_control trimmed at x = 100 mm",
            &position_mid,
            At::Trim(&[("cyl.piston.x", 0.1), ("F_load", 0.0)]),
            (&[], &[], &["spool"]),
        ),
        ("position_control at 0.3 s", &position, At::Time(0.3), (&[], &[], &["spool"])),
        ("position_control at 0.6 s", &position, At::Time(0.6), (&[], &[], &["spool"])),
        ("fed tank at 0.1 s", &tank, At::Time(0.1), (&[], &[], &["mdot", "rho"])),
    ];
    // each case's worst gaps of B, C, D, for docs/linearize.md's table
    let mut measured: Vec<(&str, [f64; 3])> = Vec::new();
    for (name, flat, at, (difference_inputs, difference_outputs, record_outputs)) in cases {
        let mut model = driven(flat);
        let op = match at {
            At::Rest => OperatingPoint { t: 0.0, y: model.initial_state(), kind: PointKind::Rest, trim: None },
            At::Time(f) => {
                let (standalone, opts) = common::model_of(flat);
                linearize::point::at_time(standalone, &mut model, &opts, f * opts.t_end).unwrap_or_else(|e| panic!("{name}: {e}"))
            }
            At::Trim(held) => {
                let constraints: Vec<linearize::trim::Constraint> = held
                    .iter()
                    .map(|&(v, value)| {
                        let (target, _) = linearize::trim::target(&model, v).unwrap_or_else(|| panic!("{name}: no variable {v}"));
                        linearize::trim::Constraint { name: v.to_string(), target, value }
                    })
                    .collect();
                let guess = model.initial_state();
                linearize::trim::trim(&mut model, &guess, &constraints, linearize::Friction::Auto).unwrap_or_else(|e| panic!("{name}: {e}"))
            }
        };
        let lm = linearize::linearize(&mut model, &op, &Options { keep_all_states: true, ..Options::default() })
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(lm.method, linearize::jacobians::Method::Exact, "{name}");
        assert_eq!(lm.difference_inputs, difference_inputs, "{name}");
        assert_eq!(lm.difference_outputs, difference_outputs, "{name}");
        assert_eq!(lm.record_difference_outputs, record_outputs, "{name}");
        let n = model.n_states;
        let kept: Vec<usize> = lm.states.iter().map(|s| (0..n).find(|&i| model.state_name(i) == s.name).unwrap()).collect();
        let (outputs, _) = linearize::output_columns(&model);
        let columns: Vec<usize> = outputs.iter().map(|o| o.1).collect();
        let exact = linearize::jacobians::jacobians(&mut model, op.t, &op.y, &kept, &columns).unwrap();
        let fd = linearize::jacobians::central_differences(&mut model, op.t, &op.y, &kept, &columns).unwrap();
        // the cost of a call, the least of 20 (printed for docs/linearize.md, never asserted)
        let mut least = |f: &mut dyn FnMut(&mut Model)| {
            (0..20)
                .map(|_| {
                    let clock = std::time::Instant::now();
                    f(&mut model);
                    clock.elapsed()
                })
                .min()
                .unwrap_or_default()
        };
        let exact_time = least(&mut |m| drop(linearize::jacobians::jacobians(m, op.t, &op.y, &kept, &columns)));
        let fd_time = least(&mut |m| drop(linearize::jacobians::central_differences(m, op.t, &op.y, &kept, &columns)));
        eprintln!("{name}: jacobians {exact_time:?}, central_differences {fd_time:?} (least of 20 calls)");
        assert_eq!(exact.a.rows(), n);
        // the linear model carries these matrices (rows of the kept states)
        for (r, &i) in kept.iter().enumerate() {
            for k in 0..model.n_inputs() {
                assert_eq!(lm.b[(r, k)], exact.b[(i, k)], "{name}: B of {} is not the exact one", lm.states[r].name);
            }
        }
        let scales = model.state_scales(&op.y);
        let x_scale: Vec<f64> = kept.iter().map(|&j| scales[j]).collect();
        let u_scale: Vec<f64> =
            (0..model.n_inputs()).map(|k| model.input_value(k).abs().max(linearize::jacobians::input_size(&model, k))).collect();
        let row_max = |x: &linear::Matrix, u: &linear::Matrix, rows: &[usize]| -> Vec<f64> {
            rows.iter()
                .map(|&i| {
                    let xs = x_scale.iter().enumerate().map(|(j, s)| (x[(i, j)] * s).abs());
                    let us = u_scale.iter().enumerate().map(|(k, s)| (u[(i, k)] * s).abs());
                    xs.chain(us).fold(0.0, f64::max)
                })
                .collect()
        };
        let state_rows: Vec<usize> = (0..n).collect();
        let out_rows: Vec<usize> = (0..columns.len()).collect();
        let f_max = row_max(&fd.a, &fd.b, &state_rows);
        let y_max = row_max(&fd.c, &fd.d, &out_rows);
        let gaps = [
            ("B", scaled_gap(&exact.b, &fd.b, &u_scale, &f_max)),
            ("C", scaled_gap(&exact.c, &fd.c, &x_scale, &y_max)),
            ("D", scaled_gap(&exact.d, &fd.d, &u_scale, &y_max)),
        ];
        eprintln!("{name}: exact against central differences, scaled relative gaps {gaps:?}");
        measured.push((name, gaps.map(|g| g.1)));
        for (which, gap) in gaps {
            assert!(gap < 1e-6, "{name}: {which} differs from central differences by {gap:e}");
        }
        // the exact columns are not the differences themselves: some input acts
        let b_norm: f64 = (0..n).flat_map(|i| (0..model.n_inputs()).map(move |k| (i, k))).map(|(i, k)| exact.b[(i, k)].abs()).sum();
        assert!(b_norm > 0.0, "{name}: B is zero");
    }
    gap_table_is_what_was_measured(&measured);
}

/// docs/linearize.md's table of the worst gaps of exact B, C, D against
/// central differences: each case's row (position_control at 0.3 s and
/// 0.6 s share one, "a / b" in each cell) reads as measured; a 0 must be
/// exactly zero (no output feeds through).
fn gap_table_is_what_was_measured(measured: &[(&str, [f64; 3])]) {
    use common::numbers::{pieces, Piece};
    let page = derivatives_page();
    let text = std::fs::read_to_string(common::repo().join("docs/linearize.md")).expect("docs/linearize.md");
    let row = |first: &str| -> Vec<Vec<(f64, String)>> {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("| {first} |")))
            .unwrap_or_else(|| panic!("docs/linearize.md lost the row {first:?}"));
        line.trim()
            .trim_matches('|')
            .split('|')
            .skip(1)
            .map(|cell| {
                pieces(cell)
                    .into_iter()
                    .filter_map(|p| match p {
                        Piece::Number(x, w) => Some((x, w)),
                        Piece::Text(_) => None,
                    })
                    .collect()
            })
            .collect()
    };
    let gaps = |name: &str| measured.iter().find(|m| m.0 == name).unwrap_or_else(|| panic!("no case {name}")).1;
    let rows: [(&str, Vec<[f64; 3]>); 4] = [
        ("closed-chamber cylinder (input F, outputs x, p_head, a) at rest", vec![gaps("closed cylinder at rest")]),
        ("position_control trimmed at x = 100 mm (u, F_load)", vec![gaps("position_control trimmed at x = 100 mm")]),
        ("position_control at 0.3 s / 0.6 s of its run", vec![gaps("position_control at 0.3 s"), gaps("position_control at 0.6 s")]),
        (
            "a supply feeding a tank through two restrictions, a mass-flow source on the junction between them (inputs p_s, T_s, q, T_feed; outputs p, T, rho, mdot) at 0.1 s",
            vec![gaps("fed tank at 0.1 s")],
        ),
    ];
    for (first, values) in rows {
        let cells = row(first);
        for (k, value) in values.iter().enumerate() {
            // the k-th number of each cell ("8.5e-15 / 8.5e-15")
            let written: Vec<Option<(f64, String)>> = cells.iter().map(|c| c.get(k).cloned()).collect();
            for (cell, v) in written.iter().zip(value) {
                if cell.as_ref().is_some_and(|c| c.1 == "0") {
                    assert_eq!(*v, 0.0, "docs/linearize.md is stale: the row {first:?} says 0, the test measured {v:e}");
                }
            }
            page.row_says(first, &written, &value.map(Some));
        }
    }
}
