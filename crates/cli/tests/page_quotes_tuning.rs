//! docs/position_control_tuning.md's prose after its linear model: every
//! figure it quotes from a run is the one the page's outputs show (the
//! ```` ```text ```` block under each Python block, which
//! crates/python/tests/test_docs_tuning.py compares with the run, and the
//! checked command outputs, which tutorial.rs compares), and the gains the
//! commands set are the tuned gains the Python block prints. Numbers by the
//! shared rule (common/quotes.rs: to the digits shown, within 0.5 %).

mod common;

use common::numbers::numbers_in as numbers;
use common::quotes::Page;

/// The page's output lines, read by their start.
struct Outputs(Vec<String>);

impl Outputs {
    /// The numbers of the only output line starting with `start`.
    fn line(&self, start: &str) -> Vec<f64> {
        let found: Vec<&String> = self.0.iter().filter(|l| l.starts_with(start)).collect();
        assert_eq!(found.len(), 1, "docs/position_control_tuning.md: one output line starting {start:?}, found {found:?}");
        numbers(found[0])
    }
}

#[test]
fn position_control_tuning_md_s_prose_quotes_its_outputs() {
    let page = Page::read("docs/position_control_tuning.md");
    let out = Outputs(page.output_lines());

    // §1: "linear model: f_n = 16.188 Hz, zeta = 0.1473" / "closed form: p1 = …, p2 = …, f_n = 16.180 Hz"
    let [f_linear, zeta_linear] = out.line("linear model:")[..] else { panic!("linear model line") };
    let closed = out.line("closed form:");
    let f_closed = closed[closed.len() - 1];
    let zeta_friction = *out.line("friction alone:").last().expect("ζ");
    // the dry friction of the checked linearize output: "… c = 29.5716 N s/m only; the dry
    // friction (Coulomb 10.2926 N, breakaway …)"
    let coulomb = out.line("cyl.piston: sliding")[3];
    page.says("The piston is linearised sliding about v = 0: the dry friction (about", &[Some(coulomb)]);
    page.says("a net force below the breakaway level (about", &[Some(coulomb)]);
    page.says("adiabatic, is within", &[Some(100.0 * (f_closed / f_linear - 1.0).abs())]);
    page.says("They add damping: ζ =", &[Some(zeta_linear), Some(zeta_friction)]);
    page.says("this small cylinder with 1 kg is at", &[Some(f_linear)]);

    // §2: the rule's ratios of the shipped gains (kp 30, ki 3, kd 0.1: the netlist's, and the
    // Python block's `pid(30, 3, 0.1)`)
    page.says("keep the shipped ratios kp : ki : kd (integral time kp/ki =", &[Some(30.0 / 3.0), Some(0.1 / 30.0 * 1e3)]);
    let [gm_shipped, _, _] = out.line("shipped: gain margin")[..] else { panic!("shipped margins") };
    // "tuned: kp = 15.12 1/m, ki = 1.512 1/(m s), kd = 0.0504 s/m" (the units' 1s are numbers too)
    let [kp, _, ki, _, kd] = out.line("tuned: kp =")[..] else { panic!("tuned gains") };
    let [_, _, crossover] = out.line("tuned: gain margin")[..] else { panic!("tuned margins") };
    let linear_step = out.line("linear step:");
    let (linear_overshoot, linear_settling) = (linear_step[0], linear_step[2]);
    page.says("at the edge of stability in the linear model at mid-stroke (gain margin", &[Some(gm_shipped), Some(f_linear)]);
    page.says("the linear model predicts an almost first-order response with crossover at", &[Some(crossover)]);

    // §3: the commands and the Python block set the tuned gains as printed
    page.says("pneumo simulate models/position_control.json --set controller.kp=", &[Some(kp)]);
    page.says("--set controller.ki=", &[Some(ki)]);
    page.says("--set \"controller.kd=", &[Some(kd)]);
    page.says("\"tuned\": (", &[Some(kp), Some(ki), Some(kd)]);
    // "shipped 0 -> 100 mm: overshoot 0.4 %, settling 0.167 s, x at the end 99.80 mm"
    let step = |name: &str, from: u32, to: u32| out.line(&format!("{name} {from} -> {to} mm:"));
    let large = [(0, 100), (100, 50), (50, 150)];
    let range = |name: &str, k: usize| {
        let v: Vec<f64> = large.iter().map(|&(a, b)| step(name, a, b)[k]).collect();
        (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(0.0, f64::max))
    };
    let (tuned_fast, tuned_slow) = range("tuned", 3);
    let (shipped_fast, shipped_slow) = range("shipped", 3);
    let worst_overshoot = range("tuned", 2).1.max(range("shipped", 2).1);
    // "100 mm at kp = 15 asks for u = 1.5" (the step times the tuned kp)
    page.says("100 mm at kp =", &[Some(kp), Some(0.1 * kp)]);
    // "…crossover, so the linear 0.290 s is no prediction for these steps: the tuned gains
    // settle them in 0.26–0.34 s, the shipped (twice as high) in 0.17–0.18 s, both with under 1 % overshoot"
    page.says(
        "set by that speed and by the band, not by the",
        &[Some(crossover), Some(linear_settling), Some(tuned_fast), Some(tuned_slow), Some(shipped_fast), Some(shipped_slow)],
    );
    let under = page.numbers_after("both with under", 1)[0].0;
    assert!(
        worst_overshoot < under,
        "docs/position_control_tuning.md is stale: the large steps overshoot by up to {worst_overshoot} %, the page says under {under} %"
    );
    // the small step: "overshoots by 2.1 % where the linear model predicted 1.0 %, and sticks at
    // 105.11 mm, 0.11 mm past the setpoint and just outside the ±0.1 mm band"
    let small = step("tuned", 100, 105);
    // "tuned 100 -> 105 mm: overshoot 2.1 %, settling not settled, x at the end 105.11 mm"
    let (small_overshoot, small_end) = (small[2], *small.last().expect("x at the end"));
    let settled = !out.0.iter().any(|l| l.starts_with("tuned 100 -> 105 mm:") && l.contains("not settled"));
    assert!(!settled, "docs/position_control_tuning.md: the prose says the tuned 5 mm step does not settle in the window");
    page.says(
        "The 5 mm step with the tuned gains overshoots by",
        &[Some(small_overshoot), Some(linear_overshoot), Some(small_end), Some(small_end - 105.0), Some(0.02 * 5.0)],
    );
    assert!(small_end - 105.0 > 0.1, "the page says the tuned step sticks outside the ±0.1 mm band: it ends at {small_end} mm");
    // "the integral (1.5 1/(m s), slow by design: 10 s integral time)"
    page.says("the integral (", &[Some(ki), None, Some(kp / ki)]);
    let shipped_small = step("shipped", 100, 105);
    page.says("With the shipped gains the piston overshoots", &[Some(shipped_small[2]), Some(shipped_small[3])]);
    // "(u₀ = −0.00148, P → B)": the trim page_quotes.rs compares with linearize
    let u0 = page.numbers_after("The trimmed valve command is u₀ =", 1)[0].0;
    page.says("where it was trimmed (u₀ =", &[Some(u0)]);
}
