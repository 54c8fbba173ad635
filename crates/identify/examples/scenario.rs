//! Development driver: one synthetic scenario through the workflow, with timing.
//! Usage: scenario EFFECT|none SEED CYCLES; env knobs RTOL, ATOL, FIT_INTERVAL, FD, FTOL, MAXIT, HORIZONS,
//! SCREENIT, CALIB, NOSCREEN, BASEONLY, REFIT, NOPERTURB (see below).
use identify::synth::*;
use std::path::Path;
struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let effect = a.get(1).cloned().unwrap_or("none".into());
    let seed: u64 = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let cycles: u64 = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(2);
    let mut base = graph::load(&Fs, Path::new("models/meter_out.json")).unwrap();
    graph::apply_set(&mut base, "controller.dwell_extended=0.2").unwrap();
    graph::apply_set(&mut base, "controller.dwell_retracted=0.2").unwrap();
    let l = 1e-3 / 60.0 / 1e5;
    let hidden: Option<(String, Vec<f64>)> = match effect.as_str() {
        "none" => None,
        "piston_seal_leak" => Some((effect.clone(), vec![0.3 * l])),
        "dead_volume" => Some((effect.clone(), vec![30e-6, 0.0])),
        "valve_delay" => Some((effect.clone(), vec![0.01])),
        "stribeck_friction" => Some((effect.clone(), vec![3.0, 0.02])),
        "heat_transfer" => Some((effect.clone(), vec![1.0])),
        "supply_droop" => Some((effect.clone(), vec![200.0 * l, 0.5e-3])),
        "real_gas" => Some((effect.clone(), vec![])),
        _ => panic!("unknown"),
    };
    if effect == "heat_transfer" {
        for id in ["head", "rod"] {
            identify::netlist_edit::set_param_si(&mut base, id, "tau_thermal", f64::INFINITY).unwrap();
        }
    }
    let mut rng = Rng::new(seed.wrapping_mul(7919).wrapping_add(17));
    let mut perturb = draw_perturbation(&["friction.k0", "friction.k2", "flow_control.C", "dcv.C"], &mut rng);
    if std::env::var("NOPERTURB").is_ok() {
        perturb.clear();
    }
    let settings = TruthSettings { cycles: Some(cycles), duration: 60.0, ..TruthSettings::default() };
    let sc =
        Scenario { hidden, operating_points: standard_operating_points(), perturb: perturb.clone(), truth_only: vec![], settings, seed };
    let t0 = std::time::Instant::now();
    let (model, exps) = sc.generate(&base).unwrap();
    println!(
        "generated in {:.2}s; perturb {:?}; samples {:?}",
        t0.elapsed().as_secs_f64(),
        perturb,
        exps.iter().map(|e| e.times.len()).collect::<Vec<_>>()
    );
    for e in &exps {
        println!("  {} sigma {:?}", e.name, e.channels.iter().map(|c| c.sigma).collect::<Vec<_>>());
    }
    let mut opts = identify::Options::default();
    if let Ok(r) = std::env::var("RTOL") {
        opts.sim.rtol = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("ATOL") {
        opts.sim.atol = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("FIT_INTERVAL") {
        opts.fit_interval = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("FD") {
        opts.fit.fd_step = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("FTOL") {
        opts.fit.ftol = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("MAXIT") {
        opts.fit.max_iter = r.parse().unwrap();
    }
    if let Ok(h) = std::env::var("HORIZONS") {
        opts.fit.horizons = h.split(',').map(|x| x.parse().unwrap()).collect();
    }
    if let Ok(r) = std::env::var("SCREENIT") {
        opts.screen_iter = r.parse().unwrap();
    }
    if std::env::var("CALIB").is_ok() {
        opts.screen_fraction = None;
        opts.thresholds.ic = -1e12;
        opts.thresholds.z_null = 0.0;
        opts.thresholds.bound_margin = 0.0;
        opts.thresholds.heldout_gain = -1e12;
        opts.max_effects = 1;
    }
    if std::env::var("NOSCREEN").is_ok() {
        opts.screen_fraction = None;
    }
    if std::env::var("BASEONLY").is_ok() {
        opts.effects = Some(vec![]);
    }
    if std::env::var("REFIT").is_ok() {
        opts.heldout = identify::workflow::HeldOut::Refit { max_iter: 4 };
    }
    let calib = identify::problem::default_calibration(&model);
    let t0 = std::time::Instant::now();
    let out = identify::run(&model, &exps, &calib, &opts).unwrap();
    let s = &out.summary;
    println!("workflow {:.2}s, {} evaluations {:?}", t0.elapsed().as_secs_f64(), s.evaluations, s.timing);
    println!(
        "baseline chi2/N {:.3} heldout {:.3} rmse {:?} [{} {} ev {}]",
        s.baseline.chi2 / s.baseline.n as f64,
        s.baseline.heldout_rmse,
        s.baseline.rmse_normalized,
        s.baseline.converged,
        s.baseline.fit_message,
        s.baseline.fit_evaluations
    );
    for p in &s.baseline.params {
        println!("   {} = {:.4e} ({:?})", p.name, p.value, p.ci95);
    }
    for c in &s.candidates {
        println!(
            "  r{} {:18} dIC {:10.1} chi2/N {:.3} ho {:.3} gap {:.3} ev {} params {:?} acc {} {:?}",
            c.round,
            c.effect,
            c.delta_ic,
            c.chi2 / s.baseline.n as f64,
            c.heldout_rmse,
            c.gap_explained,
            c.evaluations,
            c.params,
            c.accepted,
            c.reasons
        );
        println!("        {}", c.fit_message);
    }
    println!("verdict: {}", s.verdict);
    println!("baseline heldout {:.4}", s.baseline.heldout_rmse);
    println!("after rmse {:?} heldout {:.3}", s.after.rmse_normalized, s.after.heldout_rmse);
}
