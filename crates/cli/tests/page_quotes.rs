//! Prose numbers that restate what a page shows elsewhere: a figure quoted
//! from a ```` ```text ```` output block that tutorial.rs compares with a
//! run, or a closed form worked from the inputs the page states. Checking
//! the prose against those keeps it as true as the checked outputs
//! (common/quotes.rs: to the digits shown, within 0.5 %).

mod common;

use common::numbers::{pieces, Piece};
use common::quotes::Page;
use std::f64::consts::PI;

/// The numbers of a line, in order.
fn numbers(line: &str) -> Vec<f64> {
    pieces(line)
        .into_iter()
        .filter_map(|p| match p {
            Piece::Number(x, _) => Some(x),
            Piece::Text(_) => None,
        })
        .collect()
}

/// The closed form of docs/linearize.md's "paper's cylinder at mid-stroke"
/// (the inputs its first paragraph states: bore 45 mm, rod 15 mm, x = 225
/// mm, dead volume 20 cm³, 1 kg, p_atm = 0.98 bar, friction k2 = 50 N s/m,
/// k3 = 2e-4 N s/(m Pa), k4 = 0.9, ideal air γ = cp/cv): the rod pressure
/// that balances `p_head`, ω_n of the two adiabatic gas springs, f_n
/// adiabatic and isothermal, ζ = c/(2Mω).
fn pneumatic_spring(p_head: f64) -> [f64; 5] {
    let (a1, a2) = (PI / 4.0 * 0.045f64.powi(2), PI / 4.0 * (0.045f64.powi(2) - 0.015f64.powi(2)));
    let (x, dead, mass, p_atm) = (0.225, 20e-6, 1.0, 0.98e5);
    let gamma = 1004.85 / 717.8;
    let p_rod = (p_head * a1 - p_atm * (a1 - a2)) / a2;
    let stiffness_per_n = a1 * a1 * p_head / (dead + a1 * x) + a2 * a2 * p_rod / (dead + a2 * (0.45 - x));
    let omega = (gamma * stiffness_per_n / mass).sqrt();
    let f_iso = (stiffness_per_n / mass).sqrt() / (2.0 * PI);
    let c = 50.0 + 2e-4 * (p_head - 0.9 * p_rod);
    [p_rod, omega, omega / (2.0 * PI), f_iso, c / (2.0 * mass * omega)]
}

#[test]
fn linearize_md_s_paper_cylinder_prose_restates_its_checked_runs_and_closed_form() {
    let page = Page::read("docs/linearize.md").section("## The paper's cylinder at mid-stroke");
    // the closed-form table, and the 7 bar run's rod pressure (the balance)
    for (row, p_head) in [("| 4 bar |", 4e5), ("| 7 bar |", 7e5)] {
        let [p_rod, omega, f_ad, f_iso, zeta] = pneumatic_spring(p_head);
        page.says(row, &[Some(p_rod / 1e5), Some(omega), Some(f_ad), Some(f_iso), Some(zeta)]);
    }
    page.says("--set \"rod.p0=", &[Some(pneumatic_spring(7e5)[0] / 1e5)]);
    // the checked outputs: at 4 bar every mode, at 7 bar the oscillating one
    let outputs = page.output_lines();
    let oscillating: Vec<Vec<f64>> = outputs.iter().filter(|l| l.contains(" ± ")).map(|l| numbers(l)).collect();
    let lags: Vec<f64> = outputs.iter().filter(|l| l.contains("ζ = 1.0000")).map(|l| numbers(l)[0]).collect();
    assert_eq!((oscillating.len(), lags.len()), (2, 2), "the 4 and 7 bar outputs: {outputs:?}");
    // λ = re ± im j 1/s: ω_n = … rad/s (f Hz), ζ = …
    let [re4, im4, _, omega4, f4, zeta4] = oscillating[0][..] else { panic!("{:?}", oscillating[0]) };
    let [re7, im7, _, _, f7, zeta7] = oscillating[1][..] else { panic!("{:?}", oscillating[1]) };
    // "λ = −25.63 ± 81.96j 1/s at 4 bar: f_n = 13.667 Hz, ζ = 0.2985; λ = −25.26 ± …" (− is
    // typographic, so the page's number reads positive)
    let mode = |re: f64, im: f64, f: f64, zeta: f64| [Some(-re), Some(im), None, None, Some(f), Some(zeta)];
    let mut quoted = mode(re4, im4, f4, zeta4).to_vec();
    quoted.extend(mode(re7, im7, f7, zeta7));
    page.says("gives the oscillating mode λ =", &quoted);
    page.says("thermal lags (", &[Some(-lags[0]), Some(-lags[1])]);
    // "this cylinder with 1 kg moving mass is at 12–18 Hz [the isothermal closed form at 4 bar
    // to the 7 bar run], and a heavier load lowers it as 1/√M (10 Hz at about 1.9 kg at 4 bar).
    // With τ_T = 5 s the wall barely acts at these frequencies (ωτ_T ≈ 430)"
    let mass_for_10_hz = (f4 / 10.0).powi(2);
    let quoted = [None, Some(pneumatic_spring(4e5)[3]), Some(f7), None, None, Some(mass_for_10_hz), None, None, Some(omega4 * 5.0)];
    page.says("this cylinder with", &quoted);
}
