use rig::*;
fn main() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    for (label, r, tend) in [("stuck", 1000.0, 0.5), ("moving", 1.0, 0.5), ("moving-long", 1.0, 2.5), ("cycle", 1.0, 3.2)] {
        for rtol in [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10] {
            let mut form = ModelForm::default();
            form.friction.breakaway_ratio = r;
            let mut run = RunSpec::cycles(1, 1e-2);
            run.cycles = None; run.t_end = tend; run.rtol = rtol;
            let tr = simulate(&rig, &form, &Effects::default(), &run).unwrap();
            let b = tr.balance;
            println!("{label} rtol={rtol:e}: eres={:.3e} J rel={:.2e} steps={} events={}", b.energy_residual, b.energy_residual_rel, tr.stats.steps, tr.events.len());
        }
    }
}
