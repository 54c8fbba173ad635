use rig::*;
use std::time::Instant;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let rig = Rig::paper_bar_lpm(a[0], a[1]);
    let mut form = ModelForm::default();
    form.switches.dwell_retracted = a[2];
    form.switches.dwell_extended = a[2];
    if a.len() > 3 && a[3] > 0.0 { form.subsonic.laminar_width = Some(a[3]); }
    let run = RunSpec::cycles(3, 1e-3);
    let t0 = Instant::now();
    let tr = simulate(&rig, &form, &Effects::default(), &run).unwrap();
    println!("{:?}\n{:?} {:.3}s hold={:e}", tr.cycles, tr.stats, t0.elapsed().as_secs_f64(), tr.max_hold_excess);
}
