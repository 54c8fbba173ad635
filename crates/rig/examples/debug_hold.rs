use rig::*;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let rig = Rig::paper_bar_lpm(a[0], a[1]);
    let mut form = ModelForm::default();
    let shape = if a[5] > 0.0 { StribeckShape::Gaussian } else { StribeckShape::Exponential };
    form.friction = FrictionVariant { breakaway_ratio: a[2], stribeck: (a[3] > 0.0).then_some(Stribeck { velocity: a[3], shape }) };
    let mut run = RunSpec::cycles(3, 2e-3);
    run.rtol = a[4];
    let tr = simulate(&rig, &form, &Effects::default(), &run).unwrap();
    println!("hold {:e}", tr.max_hold_excess);
}
