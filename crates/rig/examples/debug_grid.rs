use rig::*;
use std::time::Instant;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let rig = Rig::paper_bar_lpm(a[0], a[1]);
    for r in [1.0, 1.5, 2.0, 3.0] {
        for vs in [0.0, 5e-3] {
            for shape in [StribeckShape::Exponential, StribeckShape::Gaussian] {
                if vs == 0.0 && shape == StribeckShape::Gaussian { continue; }
                for rtol in [1e-5, 1e-6, 1e-8] {
                    let mut form = ModelForm::default();
                    form.friction = FrictionVariant { breakaway_ratio: r, stribeck: (vs > 0.0).then_some(Stribeck { velocity: vs, shape }) };
                    let mut run = RunSpec::cycles(3, 1e-3);
                    run.rtol = rtol;
                    let t0 = Instant::now();
                    match simulate(&rig, &form, &Effects::default(), &run) {
                        Ok(tr) => println!("r={r} vs={vs} {shape:?} rtol={rtol}: {:.5} {:.5} {:.5} hold={:.2e} ev={} steps={} nf={} {:.3}s", tr.cycles[0].total, tr.cycles[1].total, tr.cycles[2].total, tr.max_hold_excess, tr.events.len(), tr.stats.steps, tr.stats.newton_failures, t0.elapsed().as_secs_f64()),
                        Err(e) => println!("r={r} vs={vs} rtol={rtol}: ERROR {e}"),
                    }
                }
            }
        }
    }
}
