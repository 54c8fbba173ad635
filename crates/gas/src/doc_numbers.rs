//! docs/gas.md's numbers against the code and the committed CoolProp
//! fixture (tests/data/coolprop_*.csv), so the page cannot go stale.
//!
//! What is recomputed here and compared with the page (numbers to the digits
//! shown, within 0.5 %, the rule of crates/cli/tests/tutorial.rs):
//! the ideal-gas constants, the ideal-gas cp and Z departures quoted against
//! CoolProp, the semi-perfect extrapolation at 1200 K, the effective B of air
//! at 300 K, and the table "On the committed fixture". The fit tables above
//! it ("Fit", "Accuracy reached") come from tests/data/make_gas_fixture.py on
//! a finer CoolProp grid that CI cannot rebuild (CoolProp is not a test
//! dependency); that grid holds every fixture state in its range, so each of
//! their maxima must be at least the fixture's, which is checked.

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
