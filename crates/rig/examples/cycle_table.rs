use rig::{simulate, Effects, ModelForm, Rig, RunSpec};
use std::time::Instant;

fn main() {
    for ps in [4.0, 7.0] {
        for c in [1.41, 2.68, 13.2, 210.0] {
            let rig = Rig::paper_bar_lpm(ps, c);
            let t0 = Instant::now();
            let tr = simulate(&rig, &ModelForm::default(), &Effects::default(), &RunSpec::cycles(3, 1e-3));
            let el = t0.elapsed().as_secs_f64();
            match tr {
                Ok(tr) => {
                    let cy: Vec<String> = tr.cycles.iter().map(|c| format!("{:.4}+{:.4}={:.4}", c.extend, c.retract, c.total)).collect();
                    println!("{ps} bar C={c}: {} | {:.3} s | {:?}", cy.join(" "), el, tr.stats);
                }
                Err(e) => println!("{ps} bar C={c}: error {e} after {el:.3} s"),
            }
        }
    }
}
