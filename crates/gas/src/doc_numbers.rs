//! docs/gas.md's numbers against the code and the committed CoolProp
//! fixture (tests/data/coolprop_*.csv), so the page cannot go stale.
//!
//! What is recomputed here and compared with the page (numbers to the digits
//! shown, within 0.5 %, the rule of crates/cli/tests/tutorial.rs):
//! the ideal-gas constants, the ideal-gas cp and Z departures quoted against
//! CoolProp, the semi-perfect extrapolation at 1200 K, the effective B of air
//! at 300 K, and the table "On the committed fixture". The fit tables above
//! it ("Fit", "Accuracy reached", and the joint fit's figures quoted in the
//! prose) are recomputed from the Rust models on the finer CoolProp grids
//! tests/data/make_gas_fixture.py writes into tests/data/coolprop_*_fine.csv
//! (committed, 263 kB each: CoolProp is not a test dependency); that grid
//! holds every fixture state in its range, so each of their maxima must also
//! be at least the fixture's, which is checked. The alternative fits the
//! prose compares with (Z alone; B and C alone) and CoolProp's second virial
//! coefficient come from the script's tests/data/gas_alternative_fits.csv.

use crate::test_support::{fixture, Row, AIR_CSV, NITROGEN_CSV};
use crate::{GasModel, IdealGas, SemiPerfectGas, VirialGas};

const PAGE: &str = include_str!("../../../docs/gas.md");

/// The numbers of a piece of text, with the words they were written as.
fn numbers(text: &str) -> Vec<(f64, String)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let boundary = i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '.' || chars[i - 1] == '_');
        if chars[i].is_ascii_digit() && boundary {
            let mut j = i;
            while j < chars.len()
                && (chars[j].is_ascii_digit() || chars[j] == '.' || chars[j] == 'e' || (chars[j] == '-' && chars[j - 1] == 'e'))
            {
                j += 1;
            }
            let word: String = chars[i..j].iter().collect::<String>().trim_end_matches('.').to_string();
            let negative = i > 0 && (chars[i - 1] == '-' || chars[i - 1] == '−');
            if let Ok(x) = word.parse::<f64>() {
                out.push((if negative { -x } else { x }, word.clone()));
            }
            i += word.chars().count().max(1);
        } else {
            i += 1;
        }
    }
    out
}

/// Half a unit of the last digit `word` is written with.
fn half_ulp(word: &str) -> f64 {
    let mantissa = word.split(['e', 'E']).next().unwrap_or(word);
    let exponent: i32 = word.split(['e', 'E']).nth(1).and_then(|e| e.parse().ok()).unwrap_or(0);
    let decimals = mantissa.split('.').nth(1).map_or(0, str::len) as i32;
    0.5 * 10f64.powi(exponent - decimals)
}

/// Fails unless `actual` reads as the page's `word` (to its digits, within 0.5 %).
fn agrees(what: &str, word: &(f64, String), actual: f64) {
    let allowed = half_ulp(&word.1) + 0.005 * word.0.abs();
    assert!((word.0 - actual).abs() <= allowed, "docs/gas.md is stale: {what}: the page says {}, the code gives {actual}", word.1);
}

/// The page's text (lines joined by single spaces) after `start`, up to `end`.
fn between(start: &str, end: &str) -> String {
    let page = PAGE.split_whitespace().collect::<Vec<_>>().join(" ");
    let from = page.find(start).unwrap_or_else(|| panic!("docs/gas.md lost the words {start:?}"));
    let rest = &page[from + start.len()..];
    let to = rest.find(end).unwrap_or_else(|| panic!("docs/gas.md: no {end:?} after {start:?}"));
    rest[..to].to_string()
}

fn rows(gas: &str) -> Vec<Row> {
    fixture(if gas == "air" { AIR_CSV } else { NITROGEN_CSV })
}

fn virial(gas: &str) -> VirialGas {
    if gas == "air" {
        VirialGas::air()
    } else {
        VirialGas::nitrogen()
    }
}

/// Largest |Z error| [%], |cp error| [%], |(h − h0) error| and |h error|
/// [J/kg] of the virial model over the fixture states in the range, Z at
/// CoolProp's (ρ, T) as in the script's table.
fn virial_errors(gas: &str, t: (f64, f64), p: (f64, f64)) -> ([f64; 4], usize) {
    let g = virial(gas);
    let mut e = [0.0_f64; 4];
    let mut n = 0;
    for r in rows(gas).iter().filter(|r| (t.0..=t.1).contains(&r.t) && (p.0..=p.1).contains(&r.p)) {
        let h = g.enthalpy(r.rho, r.t);
        let errors = [
            100.0 * (g.compressibility(r.rho, r.t) / r.z - 1.0).abs(),
            100.0 * (g.cp(r.rho, r.t) / r.cp - 1.0).abs(),
            (h - g.ideal_part().h0(r.t) - r.h_dep).abs(),
            (h - r.h).abs(),
        ];
        for (worst, x) in e.iter_mut().zip(errors) {
            *worst = worst.max(x);
        }
        n += 1;
    }
    (e, n)
}

/// A number of the page with the word it is written as.
type Word = (f64, String);
/// A range of the page: lower and upper end.
type Range = (f64, f64);

/// A table row `| gas | 250–400 K, 1–10 bar | … |`: gas, T range [K], p range [Pa], numbers.
fn accuracy_row(cells: &[&str]) -> (String, Range, Range, Vec<Word>) {
    let range: Vec<f64> = numbers(cells[1]).into_iter().map(|(x, _)| x).collect();
    assert_eq!(range.len(), 4, "range {:?}", cells[1]);
    let values: Vec<(f64, String)> = cells[2..].iter().flat_map(|c| numbers(c)).collect();
    (cells[0].to_string(), (range[0], range[1]), (range[2] * 1e5, range[3] * 1e5), values)
}

/// The rows of the table that follows the line starting with `heading`.
fn table_after(heading: &str) -> Vec<Vec<&'static str>> {
    let start = PAGE.find(heading).unwrap_or_else(|| panic!("docs/gas.md lost the paragraph starting {heading:?}"));
    PAGE[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| l.trim().trim_matches('|').split('|').map(str::trim).collect())
        .collect()
}

#[test]
fn ideal_gas_constants_are_the_code_s() {
    for (name, g, end) in [("air", IdealGas::air(), "- nitrogen"), ("nitrogen", IdealGas::nitrogen(), "For air, against")] {
        let n = numbers(&between(&format!("- {name}: R ="), end));
        assert_eq!(n.len(), 4, "{name}: R, cv, cp, γ");
        let (r, cv, cp) = (g.r(), g.cv(1.0, 300.0), g.cp(1.0, 300.0));
        for (word, (what, x)) in n.iter().zip([("R", r), ("cv", cv), ("cp", cp), ("γ", cp / cv)]) {
            agrees(&format!("{name} {what}"), word, x);
        }
    }
}

#[test]
fn ideal_gas_departures_from_coolprop_are_the_fixture_s() {
    let air = rows("air");
    let cp = IdealGas::air().cp(1.0, 300.0);
    let cp_error = |t: f64| air.iter().filter(|r| r.t == t).map(|r| 100.0 * (cp / r.cp0 - 1.0).abs()).fold(0.0, f64::max);
    // "cp is within 0.35 % of the ideal-gas cp0 between 200 and 350 K (0.84 % at 400 K, 2.4 % at 500 K)"
    let n = numbers(&between("For air, against CoolProp: cp is within", "The real Z"));
    assert_eq!(n.len(), 7, "{n:?}");
    let worst = air.iter().filter(|r| (200.0..=350.0).contains(&r.t)).map(|r| 100.0 * (cp / r.cp0 - 1.0).abs()).fold(0.0, f64::max);
    assert!(worst <= n[0].0, "cp error {worst} % between 200 and 350 K, the page says within {} %", n[0].1);
    agrees("cp error at 400 K", &n[3], cp_error(400.0));
    agrees("cp error at 500 K", &n[5], cp_error(500.0));
    // "The real Z departs from 1 by up to 0.19 % at 2 bar, … and 14 % at 300 bar (250–400 K)."
    let n = numbers(&between("The real Z departs from 1 by up to", "(250–400 K)"));
    assert_eq!(n.len(), 10, "{n:?}");
    for pair in n.chunks(2) {
        let (pct, bar) = (&pair[0], pair[1].0);
        let worst = air
            .iter()
            .filter(|r| r.p == bar * 1e5 && (250.0..=400.0).contains(&r.t))
            .map(|r| 100.0 * (r.z - 1.0).abs())
            .fold(0.0, f64::max);
        agrees(&format!("|Z − 1| of air at {bar} bar"), pct, worst);
    }
}

#[test]
fn semi_perfect_extrapolation_and_fit_are_the_code_s() {
    // "(CoolProp: 1174.4 J/(kg K) for air at 1200 K, the line gives 1172; nitrogen 1204 against 1199)"
    let n = numbers(&between("(CoolProp: ", ")."));
    assert_eq!(n.len(), 5, "{n:?}");
    agrees("semi-perfect air cp0 at 1200 K", &n[2], SemiPerfectGas::air().cp0(1200.0));
    agrees("semi-perfect nitrogen cp0 at 1200 K", &n[4], SemiPerfectGas::nitrogen().cp0(1200.0));
    // The fit table (script, 5 K grid over 200–1000 K) holds the fixture's temperatures.
    for row in table_after("| gas | max cp0 error |") {
        let g = if row[0] == "air" { SemiPerfectGas::air() } else { SemiPerfectGas::nitrogen() };
        let fixture = rows(row[0]);
        let rel = fixture.iter().map(|r| 100.0 * (g.cp0(r.t) / r.cp0 - 1.0).abs()).fold(0.0, f64::max);
        let abs = fixture.iter().map(|r| (g.cp0(r.t) - r.cp0).abs()).fold(0.0, f64::max);
        let h0 = fixture.iter().map(|r| (g.h0(r.t) - r.h0).abs()).fold(0.0, f64::max);
        for (cell, x) in [(row[1], rel), (row[3], abs), (row[4], h0)] {
            let page = &numbers(cell)[0];
            assert!(x <= page.0 + half_ulp(&page.1), "{}: the fit table says {cell}, the fixture alone gives {x}", row[0]);
        }
    }
}

#[test]
fn effective_b_of_air_is_the_code_s() {
    // "the fitted B of air at 300 K is −2.25e-4 m³/kg"
    let b = numbers(&between("the fitted B of air at 300 K is", "m³/kg"));
    agrees("effective B of air at 300 K", &b[0], VirialGas::air().virial_coefficients(300.0)[0]);
}

#[test]
fn accuracy_tables_agree_with_the_fixture() {
    let fine = table_after("**Accuracy reached**");
    let fixture_table = table_after("**On the committed fixture**");
    assert_eq!(fine.len(), 6, "the script's table");
    assert_eq!(fixture_table.len(), fine.len(), "one fixture row per row of the script's table");
    // the rows as the page writes them (`-- --nocapture` to regenerate the table)
    for ours in &fixture_table {
        let (gas, t, p, _) = accuracy_row(ours);
        let (e, _) = virial_errors(&gas, t, p);
        println!("| {gas} | {} | {:.3} % | {:.2} % | {:.0} J/kg | {:.0} J/kg |", ours[1], e[0], e[1], e[2], e[3]);
    }
    for (script, ours) in fine.iter().zip(&fixture_table) {
        let (gas, t, p, page) = accuracy_row(ours);
        let (computed, n) = virial_errors(&gas, t, p);
        assert!(n >= 10, "{gas} {t:?} {p:?}: {n} fixture states");
        assert_eq!(page.len(), 4, "{ours:?}");
        for (k, (word, x)) in page.iter().zip(computed).enumerate() {
            agrees(&format!("{gas} {} column {}", ours[1], k + 2), word, x);
        }
        // the script's grid contains these states, so its maxima are at least ours
        let (gas_s, t_s, p_s, script_values) = accuracy_row(script);
        assert_eq!((gas_s, t_s, p_s), (gas.clone(), t, p), "the two tables list the same ranges in the same order");
        for (k, (word, x)) in script_values.iter().zip(computed).enumerate() {
            assert!(
                x <= word.0 + half_ulp(&word.1) + 0.005 * word.0,
                "{gas} {}: the script's table says {} in column {}, the fixture states alone give {x}",
                script[1],
                word.1,
                k + 2
            );
        }
    }
}

/// CoolProp on the grids of the tables "Fit" and "Accuracy reached"
/// (tests/data/make_gas_fixture.py, `--fine-only` rewrites them alone).
const AIR_FINE_CSV: &str = include_str!("../../../tests/data/coolprop_air_fine.csv");
const NITROGEN_FINE_CSV: &str = include_str!("../../../tests/data/coolprop_nitrogen_fine.csv");

/// A row of a fine-grid file: the grid (0: ideal gas, T by 1 K; 10 or 300:
/// the real-gas check grid up to that many bar) and its numbers by column
/// name (None where empty).
struct FineRow {
    grid: u32,
    values: std::collections::HashMap<String, Option<f64>>,
}

impl FineRow {
    fn get(&self, name: &str) -> f64 {
        self.values.get(name).copied().flatten().unwrap_or_else(|| panic!("no {name} in a fine-grid row of grid {}", self.grid))
    }
}

fn fine(gas: &str) -> Vec<FineRow> {
    let csv = if gas == "air" { AIR_FINE_CSV } else { NITROGEN_FINE_CSV };
    let mut lines = csv.lines().filter(|l| !l.is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let values = header.iter().zip(&cells).map(|(h, c)| (h.to_string(), c.parse::<f64>().ok())).collect();
            FineRow { grid: cells[0].parse().expect("grid"), values }
        })
        .collect()
}

#[test]
fn semi_perfect_fit_table_is_the_fine_grid_s() {
    // "| air | 0.057 % | 0.040 % | 0.65 J/(kg K) | 65 J/kg |": cp0 every 1 K over 200–1000 K
    // (largest and rms relative error, largest absolute), h0 every 10 K
    let rows = table_after("| gas | max cp0 error |");
    assert_eq!(rows.len(), 2, "air and nitrogen");
    for row in rows {
        let g = if row[0] == "air" { SemiPerfectGas::air() } else { SemiPerfectGas::nitrogen() };
        let ideal: Vec<FineRow> = fine(row[0]).into_iter().filter(|r| r.grid == 0).collect();
        assert_eq!(ideal.len(), 801, "{}: T = 200..1000 K by 1 K", row[0]);
        let rel: Vec<f64> = ideal.iter().map(|r| g.cp0(r.get("T_K")) / r.get("cp0_J_kgK") - 1.0).collect();
        let max_rel = 100.0 * rel.iter().fold(0.0_f64, |a, e| a.max(e.abs()));
        let rms_rel = 100.0 * (rel.iter().map(|e| e * e).sum::<f64>() / rel.len() as f64).sqrt();
        let max_abs = ideal.iter().map(|r| (g.cp0(r.get("T_K")) - r.get("cp0_J_kgK")).abs()).fold(0.0, f64::max);
        let max_h0 =
            ideal.iter().filter(|r| r.get("T_K") % 10.0 == 0.0).map(|r| (g.h0(r.get("T_K")) - r.get("h0_J_kg")).abs()).fold(0.0, f64::max);
        for (k, x) in [max_rel, rms_rel, max_abs, max_h0].into_iter().enumerate() {
            agrees(&format!("the fit table's {} column {}", row[0], k + 2), &numbers(row[k + 1])[0], x);
        }
    }
}

/// Largest |Z error| [%], |cp error| [%], |(h − h0) error| and |h error|
/// [J/kg] of the virial model on the fine check grid `grid` in the ranges,
/// as the script's table: Z at CoolProp's (ρ, T).
fn virial_errors_fine(gas: &str, grid: u32, t: Range, p: Range) -> ([f64; 4], usize) {
    let g = virial(gas);
    let mut e = [0.0_f64; 4];
    let mut n = 0;
    for r in fine(gas).iter().filter(|r| r.grid == grid) {
        let (temp, pressure, rho) = (r.get("T_K"), r.get("p_Pa"), r.get("rho_kg_m3"));
        if !((t.0..=t.1).contains(&temp) && (p.0 * (1.0 - 1e-12)..=p.1 * (1.0 + 1e-12)).contains(&pressure)) {
            continue;
        }
        let h = g.enthalpy(rho, temp);
        let errors = [
            100.0 * (g.compressibility(rho, temp) / (pressure / (rho * g.r() * temp)) - 1.0).abs(),
            100.0 * (g.cp(rho, temp) / r.get("cp_J_kgK") - 1.0).abs(),
            (h - g.ideal_part().h0(temp) - r.get("h_dep_J_kg")).abs(),
            (h - r.get("h_J_kg")).abs(),
        ];
        for (worst, x) in e.iter_mut().zip(errors) {
            *worst = worst.max(x);
        }
        n += 1;
    }
    (e, n)
}

#[test]
fn accuracy_reached_is_the_fine_grid_s() {
    let table = table_after("**Accuracy reached**");
    assert_eq!(table.len(), 6, "the script's table");
    for row in &table {
        let (gas, t, p, page) = accuracy_row(row);
        // the 1–10 bar rows have their own pressure grid; the others share the 1–300 bar one
        let grid = if p.1 <= 10e5 { 10 } else { 300 };
        let (computed, n) = virial_errors_fine(&gas, grid, t, p);
        println!(
            "| {gas} | {} | {:.3} % | {:.2} % | {:.0} J/kg | {:.0} J/kg | ({n} states)",
            row[1], computed[0], computed[1], computed[2], computed[3]
        );
        assert!(n >= 900, "{gas} {}: {n} states of the fine grid", row[1]);
        assert_eq!(page.len(), 4, "{row:?}");
        for (k, (word, x)) in page.iter().zip(computed).enumerate() {
            agrees(&format!("the accuracy reached, {gas} {} column {}", row[1], k + 2), word, x);
        }
    }
    // "a fit to Z alone reaches 0.11 % … but leaves 1.05 % in cp and 455 J/kg in h − h0; the
    // joint fit gives 0.16 %, 0.31 % and 162 J/kg" (air, 250–400 K, 1–300 bar)
    let (joint, _) = virial_errors_fine("air", 300, (250.0, 400.0), (1e5, 300e5));
    let n = numbers(&between("the joint fit gives", "J/kg."));
    assert_eq!(n.len(), 3, "{n:?}");
    for (word, x) in n.iter().zip(joint) {
        agrees("the joint fit (air, 250–400 K, 1–300 bar)", word, x);
    }
    // "In the 200–500 K rows, Z errors above 0.3 % occur only at or below 220 K and above 160 bar
    // (ρ > 310 kg/m³), reaching 1.2 % at 200 K and 300 bar"
    let n = numbers(&between("In the 200–500 K rows, Z errors above", "cannot follow"));
    assert_eq!(n.len(), 7, "{n:?}");
    let (limit, t_below, p_above, rho_above) = (n[0].0, n[1].0, n[2].0 * 1e5, n[3].0);
    for gas in ["air", "nitrogen"] {
        let g = virial(gas);
        let mut worst = (0.0_f64, 0.0, 0.0);
        for r in fine(gas).iter().filter(|r| r.grid == 300) {
            let (temp, pressure, rho) = (r.get("T_K"), r.get("p_Pa"), r.get("rho_kg_m3"));
            let e = 100.0 * (g.compressibility(rho, temp) / (pressure / (rho * g.r() * temp)) - 1.0).abs();
            if e > limit {
                assert!(
                    temp <= t_below && pressure > p_above && rho > rho_above,
                    "docs/gas.md is stale: {gas}'s Z error is {e:.3} % at {temp} K, {:.1} bar, {rho:.0} kg/m³",
                    pressure / 1e5
                );
            }
            if e > worst.0 {
                worst = (e, temp, pressure);
            }
        }
        assert_eq!(
            (worst.1, (worst.2 / 1e5).round()),
            (n[5].0, n[6].0),
            "docs/gas.md: {gas}'s largest Z error is at {} K, {} bar",
            worst.1,
            worst.2 / 1e5
        );
        agrees(&format!("{gas}'s largest Z error"), &n[4], worst.0);
    }
}

const ALTERNATIVES_CSV: &str = include_str!("../../../tests/data/gas_alternative_fits.csv");

/// The row of tests/data/gas_alternative_fits.csv for `gas` and `fit`
/// (joint, z_alone, b_and_c): largest Z, cp errors [%], h − h0, h errors
/// [J/kg] over 250–400 K × 1–300 bar, and CoolProp's B at 300 K [m³/kg].
fn alternative(gas: &str, fit: &str) -> [f64; 5] {
    let row = ALTERNATIVES_CSV
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|c| c[0] == gas && c[1] == fit)
        .unwrap_or_else(|| panic!("tests/data/gas_alternative_fits.csv has no row {gas},{fit}"));
    let x: Vec<f64> = row[2..].iter().map(|c| c.parse().expect("a number")).collect();
    x.try_into().expect("five numbers")
}

#[test]
fn alternative_fits_and_coolprop_b_are_the_script_s() {
    // The file's joint fit is the shipped one: its errors are those the Rust model
    // gives on the fine grid (so the file was written by the script that made the code's fit).
    for gas in ["air", "nitrogen"] {
        let (rust, _) = virial_errors_fine(gas, 300, (250.0, 400.0), (1e5, 300e5));
        let file = alternative(gas, "joint");
        for (k, (a, b)) in rust.iter().zip(file).enumerate() {
            assert!((a - b).abs() <= 0.01 * b.abs(), "{gas}: the file's joint fit column {k} is {b}, the code gives {a}: rerun the script");
        }
    }
    // "a fit to Z alone reaches 0.13 % in Z for air (250–400 K, 1–300 bar) but leaves
    // 1.04 % in cp and 457 J/kg in h − h0"
    let n = numbers(&between("a fit to Z alone reaches", "; the joint fit"));
    assert_eq!(n.len(), 7, "{n:?}");
    let z_alone = alternative("air", "z_alone");
    for (word, x) in [(&n[0], z_alone[0]), (&n[5], z_alone[1]), (&n[6], z_alone[2])] {
        agrees("the fit to Z alone (air)", word, x);
    }
    // "the fitted B of air at 300 K is −2.25e-4 m³/kg against CoolProp's second virial
    // coefficient −2.68e-4 m³/kg"
    let b = numbers(&between("against CoolProp's second virial coefficient", "m³/kg"));
    agrees("CoolProp's second virial coefficient of air at 300 K", &b[0], alternative("air", "joint")[4]);
    // "with B and C alone the same fit reaches only 0.71 % (air) and 0.68 % (nitrogen) in Z"
    let n = numbers(&between("with B and C alone the same fit reaches only", "in Z over"));
    assert_eq!(n.len(), 2, "{n:?}");
    agrees("B and C alone (air)", &n[0], alternative("air", "b_and_c")[0]);
    agrees("B and C alone (nitrogen)", &n[1], alternative("nitrogen", "b_and_c")[0]);
}
