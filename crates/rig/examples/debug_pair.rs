use rig::*;
fn main() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let rtol: f64 = std::env::args().nth(1).unwrap().parse().unwrap();
    let mut last = 0.0;
    for k in 0..=60 {
        let t_end = 2.86 + 0.0015 * k as f64;
        let run = RunSpec { rtol, cycles: None, t_end, ..RunSpec::cycles(3, 1e-2) };
        let tr = simulate(&rig, &ModelForm::default(), &Effects::default(), &run).unwrap();
        let n = tr.t.len() - 1;
        let r = tr.balance.energy_residual;
        println!("t={t_end:.4} eres={r:.3e} d={:.2e} x={:.4} v={:.3} p1={:.0} p2={:.0} T1={:.1} T2={:.1} ev={} steps={}", r - last, tr.x[n], tr.v[n], tr.p1[n], tr.p2[n], tr.temp1[n], tr.temp2[n], tr.events.len(), tr.stats.steps);
        last = r;
    }
}
