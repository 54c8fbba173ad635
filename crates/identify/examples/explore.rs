//! Scratch: visibility of each effect and integrator error (development aid).
use identify::synth::*;
use std::path::Path;
struct Fs;
impl graph::Loader for Fs {
    fn read(&self, p: &Path) -> Result<String, String> {
        std::fs::read_to_string(p).map_err(|e| e.to_string())
    }
}
fn rms(a: &solve::SimResult, b: &solve::SimResult, col: &str, sigma: f64) -> f64 {
    let ca = a.column(col).unwrap();
    let cb = b.column(col).unwrap();
    let va: Vec<Option<f64>> = a.rows.iter().map(|r| r[ca]).collect();
    let vb: Vec<Option<f64>> = b.rows.iter().map(|r| r[cb]).collect();
    let mut s = 0.0;
    let mut n = 0;
    let mut t = 0.0;
    while t < 6.0 {
        let x = interpolate(&a.times, &va, t).unwrap();
        let y = interpolate(&b.times, &vb, t).unwrap();
        s += ((x - y) / sigma).powi(2);
        n += 1;
        t += 1e-3;
    }
    (s / n as f64).sqrt()
}
fn main() {
    let mut base = graph::load(&Fs, Path::new("models/meter_out.json")).unwrap();
    graph::apply_set(&mut base, "controller.dwell_extended=0.3").unwrap();
    graph::apply_set(&mut base, "controller.dwell_retracted=0.3").unwrap();
    let args: Vec<String> = std::env::args().collect();
    let mut s = TruthSettings::default();
    s.duration = 6.0;
    let ops = standard_operating_points();
    let run = |f: &graph::FlatNetlist, rtol: f64, dt: f64| {
        let mut ss = s.clone();
        ss.rtol = rtol;
        ss.fine_interval = dt;
        let t0 = std::time::Instant::now();
        let r = simulate_fine(f, &ss).unwrap();
        (r, t0.elapsed().as_secs_f64())
    };
    if args.len() > 1 && args[1] == "vd" {
        for op in &ops {
            for rtol in [1e-8, 1e-6, 1e-4] {
                for dwell in ["0", "0.3"] {
                    let mut f = base.clone();
                    graph::apply_set(&mut f, &format!("controller.dwell_extended={dwell}")).unwrap();
                    graph::apply_set(&mut f, &format!("controller.dwell_retracted={dwell}")).unwrap();
                    for x in op {
                        graph::apply_set(&mut f, x).unwrap();
                    }
                    for st in [0.002, 0.01, 0.03] {
                        graph::apply_set(&mut f, &format!("dcv.switching_time={st}")).unwrap();
                        let mut ss = s.clone();
                        ss.rtol = rtol;
                        let r = simulate_fine(&f, &ss);
                        println!("{op:?} rtol {rtol} dwell {dwell} st {st}: {}", match r { Ok(_) => "ok".to_string(), Err(e) => e });
                    }
                }
            }
        }
        return;
    }
    if args.len() > 1 && args[1] == "rtol" {
        for op in &ops {
            let mut f = base.clone();
            for x in op {
                graph::apply_set(&mut f, x).unwrap();
            }
            let (truth, tt) = run(&f, 1e-8, 3e-4);
            println!("{op:?}: truth {tt:.3}s cycles {:?}", truth.cycles.iter().map(|c| c.total).collect::<Vec<_>>());
            for rtol in [1e-4, 3e-5, 1e-5, 1e-6] {
                for dt in [1e-3, 4e-3] {
                    let (r, t) = run(&f, rtol, dt);
                    println!("  rtol {rtol:e} dt {dt}: {:.1} ms  p1 {:.3} p2 {:.3} x {:.3}", t * 1e3, rms(&truth, &r, "head.p", 500.0), rms(&truth, &r, "rod.p", 500.0), rms(&truth, &r, "piston.x", 20e-6));
                }
            }
        }
        return;
    }
    let cases: Vec<(&str, Vec<f64>)> = vec![
        ("piston_seal_leak", vec![0.1e-3 / 60.0 / 1e5]),
        ("piston_seal_leak", vec![0.3e-3 / 60.0 / 1e5]),
        ("piston_seal_leak", vec![1.0e-3 / 60.0 / 1e5]),
        ("dead_volume", vec![10e-6, 0.0]),
        ("dead_volume", vec![30e-6, 0.0]),
        ("dead_volume", vec![0.0, 30e-6]),
        ("valve_delay", vec![0.01]),
        ("valve_delay", vec![0.03]),
        ("stribeck_friction", vec![1.5, 0.01]),
        ("stribeck_friction", vec![2.5, 0.02]),
        ("supply_droop", vec![200e-3 / 60.0 / 1e5, 0.5e-3]),
        ("supply_droop", vec![100e-3 / 60.0 / 1e5, 0.3e-3]),
        ("real_gas", vec![]),
        ("heat_transfer", vec![0.2]),
        ("heat_transfer", vec![1.0]),
    ];
    for (name, vals) in cases {
        let e = identify::effects::by_name(name).unwrap();
        print!("{name} {vals:?}:");
        for op in &ops {
            let mut f = base.clone();
            for x in op {
                graph::apply_set(&mut f, x).unwrap();
            }
            if name == "heat_transfer" {
                for id in ["head", "rod"] {
                    identify::netlist_edit::set_param_si(&mut f, id, "tau_thermal", f64::INFINITY).unwrap();
                }
            }
            let (a, _) = run(&f, 1e-8, 1e-3);
            let mut g = f.clone();
            e.apply(&mut g, &vals).unwrap();
            let (b, _) = run(&g, 1e-8, 1e-3);
            print!("  [{:.1} {:.1} {:.1}]", rms(&a, &b, "head.p", 500.0), rms(&a, &b, "rod.p", 500.0), rms(&a, &b, "piston.x", 20e-6));
        }
        println!();
    }
}
#[allow(dead_code)]
fn vd() {}
