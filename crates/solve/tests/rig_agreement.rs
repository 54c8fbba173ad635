//! The shipped `models/meter_out.json` against the independent meter-out
//! model (`crates/rig`: its own equations, integrator, friction and events),
//! for the paper's four throttle settings (Table 1) at 4 and 7 bar, changing
//! nothing but `supply.p` and `flow_control.C` — the rest state must carry the
//! supply pressure into the rod chamber by itself (issue: a literal
//! `rod.p0 = 4 bar` made the first cycle at 7 bar 42 % short).
//!
//! The reference values are the rig's cycle times at rtol 1e-8, recorded and
//! re-checked by `crates/rig/tests/cycle_table.rs`.

mod common;

use common::*;

/// (switch, C [L/min/bar], p_s [bar], rig cycle 1 [s], rig cycle 3 [s]).
const RIG: [(u32, f64, f64, f64, f64); 8] = [
    (4, 1.41, 4.0, 26.1613, 20.1859),
    (3, 2.68, 4.0, 13.8710, 10.7882),
    (2, 13.2, 4.0, 2.9754, 2.3783),
    (1, 210.0, 4.0, 0.3882, 0.3578),
    (4, 1.41, 7.0, 25.6354, 19.1454),
    (3, 2.68, 7.0, 13.5861, 10.2359),
    (2, 13.2, 7.0, 2.8956, 2.2452),
    (1, 210.0, 7.0, 0.3447, 0.3119),
];

#[test]
fn shipped_meter_out_matches_the_independent_model_at_4_and_7_bar() {
    let mut worst: f64 = 0.0;
    for (sw, c, ps, rig1, rig3) in RIG {
        let flat = flat_from_model("meter_out.json", &[&format!("supply.p={ps} bar"), &format!("flow_control.C={c} L/min/bar")]);
        let r = run_with(&flat, |o| {
            o.cycles = Some(3);
            o.sample_interval = 0.0;
        });
        assert_eq!(r.cycles.len(), 3, "switch {sw}, {ps} bar");
        let (c1, c3) = (r.cycles[0].total, r.cycles[2].total);
        let (e1, e3) = ((c1 - rig1) / rig1, (c3 - rig3) / rig3);
        println!(
            "switch {sw} {ps} bar: cycle 1 {c1:.4} s (rig {rig1}, {:+.3} %), cycle 3 {c3:.4} s (rig {rig3}, {:+.3} %)",
            100.0 * e1,
            100.0 * e3
        );
        worst = worst.max(e1.abs()).max(e3.abs());
        // two implementations of the same equations: 0.02 % apart when recorded, far
        // inside the paper's 3.5 % and the 3 % asked of the shipped model
        assert!(e1.abs() < 1e-3 && e3.abs() < 1e-3, "switch {sw}, {ps} bar: {c1} / {c3} s against the rig's {rig1} / {rig3} s");
    }
    println!("largest deviation {:.3} %", 100.0 * worst);
}
