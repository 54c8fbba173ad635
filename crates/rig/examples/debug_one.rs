use rig::{simulate, Effects, ModelForm, Rig, RunSpec};
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let rig = Rig::paper_bar_lpm(a[0], a[1]);
    let mut run = RunSpec::cycles(a.get(2).map_or(3, |v| *v as usize), 1e-3);
    if let Some(r) = a.get(3) { run.rtol = *r; }
    match simulate(&rig, &ModelForm::default(), &Effects::default(), &run) {
        Ok(tr) => { for c in &tr.cycles { println!("{:?}", c); } println!("{:?} hold {}", tr.stats, tr.max_hold_excess); println!("{:?}", tr.balance); }
        Err(e) => println!("error {e}"),
    }
}
