use rig::*;
use std::time::Instant;
fn main() {
    let rig = Rig::paper_bar_lpm(4.0, 13.2);
    let form = ModelForm::default();
    let mut cases: Vec<(&str, Effects)> = vec![("none", Effects::default())];
    cases.push(("leak iso 0.3", Effects { seal_leak: Some(LeakLaw::Iso(Restriction::lpm_per_bar(0.3, 0.3))), ..Effects::default() }));
    cases.push(("leak laminar", Effects { seal_leak: Some(LeakLaw::Laminar { k: 1e-12 }), ..Effects::default() }));
    cases.push(("delay 30ms", Effects { valve_delay: 0.03, ..Effects::default() }));
    cases.push(("extra vol 50cm3 head", Effects { extra_volume_head: 50e-6, ..Effects::default() }));
    cases.push(("extra vol 50cm3 rod", Effects { extra_volume_rod: 50e-6, ..Effects::default() }));
    cases.push(("stribeck 2.5 20mm/s", Effects { friction: Some(FrictionVariant { breakaway_ratio: 2.5, stribeck: Some(Stribeck { velocity: 0.02, shape: StribeckShape::Gaussian }) }), ..Effects::default() }));
    cases.push(("droop 200 L/min/bar 1 L", Effects { supply_line: Some(SupplyLine { restriction: Restriction::lpm_per_bar(200.0, 0.3), volume: 1e-3, tau_thermal: 1.0 }), ..Effects::default() }));
    cases.push(("adiabatic", Effects { tau_thermal: Some(f64::INFINITY), ..Effects::default() }));
    cases.push(("tau 1 s", Effects { tau_thermal: Some(1.0), ..Effects::default() }));
    cases.push(("real gas", Effects { real_gas: true, ..Effects::default() }));
    for (name, fx) in cases {
        let t0 = Instant::now();
        match simulate(&rig, &form, &fx, &RunSpec::cycles(3, 1e-3)) {
            Ok(tr) => println!("{name:>26}: {:.5} {:.5} {:.5} | steps {} | {:.3}s | mres {:.1e} erel {:.1e} hold {:.1e} psup_min {:.0}", tr.cycles[0].total, tr.cycles[1].total, tr.cycles[2].total, tr.stats.steps, t0.elapsed().as_secs_f64(), tr.balance.mass_residual, tr.balance.energy_residual_rel, tr.max_hold_excess, tr.p_supply.iter().cloned().fold(f64::INFINITY, f64::min)),
            Err(e) => println!("{name}: ERROR {e}"),
        }
    }
}
