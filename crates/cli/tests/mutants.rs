//! Seeded netlist mutants through `pneumo check` and `pneumo simulate`: a
//! mutation fuzzer for the netlist reader, the circuit builder and the
//! solver's guards.
//!
//! Each mutant starts from a shipped model (`models/*.json`) and applies one
//! to three edits: structural ones on the parsed JSON (drop, duplicate or
//! retype a component, rewire a connection, replace a parameter or setting by
//! a hostile value — negative, zero, huge, non-finite, wrong unit, an
//! expression with a cycle or an unknown name, control characters) and
//! textual ones on the bytes (truncate, flip, insert). Every run must end
//! cleanly: exit 0, or exit 1/2/3 with exactly one non-empty `error:` line on
//! stderr (warnings aside); never a panic (101), a signal or a hang (each
//! run has a 60 s limit); an output that is not complete is not written.
//!
//! CI runs `PNEUMO_MUTANTS` (default 60) mutants from a fixed seed; the long
//! run of docs/reliability.md is
//! `PNEUMO_MUTANTS=2000 cargo test --release -p pneumo-cli --test mutants -- --nocapture`.
//! The counts of the default runs (mutants, passed `check`, simulated,
//! fitted; runs of the extreme-float test) are compared with the CI rows of
//! docs/reliability.md's tables, so the page states what CI ran. They follow
//! the shipped models: adding one to `models/` changes them (update the page).

mod common;

use common::quotes::Page;
use common::{pneumo_in as pneumo, Scratch};
use serde_json::Value;
use std::path::Path;
use std::process::Output;

/// xorshift64*: a small deterministic generator (no dependency, same
/// sequence on every machine).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const HOSTILE_VALUES: &[&str] = &[
    "0",
    "-1",
    "-4 bar",
    "1e308",
    "1e999 bar",
    "nan",
    "inf",
    "-inf K",
    "",
    "4 m",
    "3 furlongs",
    "= nonsense_name * 2",
    "= supply.p + 1 m",
    "= 1/0",
    "bar 4",
    "4 bar bar",
    "\u{1b}[31mred\u{0}",
    "1e-300 L",
    "0 K",
    "-273.15 degC",
    "5e-324 bar",
    "-1e300 mm",
];

/// Floats at the ends of the f64 range: messages must print them readably.
const EXTREME_FLOATS: &[f64] = &[1e300, -1e300, 5e-324, f64::MAX, -f64::MIN_POSITIVE];

fn hostile_json(rng: &mut Rng) -> Value {
    match rng.below(8) {
        0 => Value::from(-1.0),
        1 => Value::from(0),
        2 => Value::from(EXTREME_FLOATS[rng.below(EXTREME_FLOATS.len())]),
        3 => Value::Null,
        4 => Value::Bool(true),
        5 => serde_json::json!([1, "x", {"a": null}]),
        6 => serde_json::json!({"nested": {"deep": [[[]]]}}),
        _ => Value::from(HOSTILE_VALUES[rng.below(HOSTILE_VALUES.len())]),
    }
}

/// Every (object, key) and (array, index) path in `v`.
fn paths(v: &Value, here: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                here.push(k.clone());
                out.push(here.clone());
                paths(c, here, out);
                here.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                here.push(i.to_string());
                out.push(here.clone());
                paths(c, here, out);
                here.pop();
            }
        }
        _ => {}
    }
}

fn parent_mut<'a>(v: &'a mut Value, path: &[String]) -> Option<&'a mut Value> {
    let mut cur = v;
    for p in &path[..path.len() - 1] {
        cur = match cur {
            Value::Object(m) => m.get_mut(p)?,
            Value::Array(a) => a.get_mut(p.parse::<usize>().ok()?)?,
            _ => return None,
        };
    }
    Some(cur)
}

/// One structural edit of the parsed netlist.
fn mutate_json(v: &mut Value, rng: &mut Rng) {
    let mut all = Vec::new();
    paths(v, &mut Vec::new(), &mut all);
    if all.is_empty() {
        return;
    }
    // half the edits hit a parameter, an initial value or a setting, so that
    // mutants get past the reader and exercise the builder and the solver
    let values: Vec<&Vec<String>> = all
        .iter()
        .filter(|p| p.len() >= 3 && p.iter().any(|k| k == "params" || k == "init") || p.first().is_some_and(|k| k == "simulation"))
        .collect();
    let path =
        if !values.is_empty() && rng.below(2) == 0 { values[rng.below(values.len())].clone() } else { all[rng.below(all.len())].clone() };
    let last = path.last().cloned().unwrap_or_default();
    let donor = {
        let d = &all[rng.below(all.len())];
        let mut cur = &*v;
        for p in d {
            cur = match cur {
                Value::Object(m) => &m[p],
                Value::Array(a) => &a[p.parse::<usize>().unwrap()],
                _ => break,
            };
        }
        cur.clone()
    };
    let Some(parent) = parent_mut(v, &path) else { return };
    match (parent, rng.below(5)) {
        (Value::Object(m), 0) => {
            m.remove(&last);
        }
        (Value::Array(a), 0) => {
            if let Ok(i) = last.parse::<usize>() {
                if i < a.len() {
                    a.remove(i);
                }
            }
        }
        (Value::Array(a), 1) => {
            if let Ok(i) = last.parse::<usize>() {
                if let Some(x) = a.get(i).cloned() {
                    a.push(x); // a duplicated component or connection
                }
            }
        }
        (Value::Object(m), 2) => {
            m.insert(last, donor); // a value from elsewhere in the file (wrong kind, a real id, ...)
        }
        (Value::Array(a), 2) => {
            if let Ok(i) = last.parse::<usize>() {
                if i < a.len() {
                    a[i] = donor;
                }
            }
        }
        (Value::Object(m), _) => {
            m.insert(last, hostile_json(rng));
        }
        (Value::Array(a), _) => {
            if let Ok(i) = last.parse::<usize>() {
                if i < a.len() {
                    a[i] = hostile_json(rng);
                }
            }
        }
        _ => {}
    }
}

/// One edit of the bytes.
fn mutate_text(t: &mut Vec<u8>, rng: &mut Rng) {
    if t.is_empty() {
        return;
    }
    let i = rng.below(t.len());
    match rng.below(3) {
        0 => t.truncate(i),
        1 => t[i] ^= 1 << rng.below(8),
        _ => t.insert(i, [b'{', b'"', b'\\', b'\0', 0xff, b']', b'9'][rng.below(7)]),
    }
}

/// The run ended cleanly; returns whether it succeeded.
fn clean(out: &Output, what: &str) -> bool {
    let err = String::from_utf8_lossy(&out.stderr);
    match out.status.code() {
        Some(0) => true,
        Some(1..=3) => {
            let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("warning: ")).collect();
            assert!(
                lines.len() == 1 && lines[0].starts_with("error: ") && lines[0].len() > "error: ".len(),
                "{what}: expected one error line, got:\n{err}"
            );
            assert!(!lines[0].chars().any(|c| c.is_control()), "{what}: control character in {:?}", lines[0]);
            err.lines().for_each(|l| assert_readable(l, what));
            false
        }
        code => panic!("{what}: exit {code:?} (101 is a panic, None a signal); stderr:\n{err}"),
    }
}

/// Longest line of a message [bytes].
const MAX_LINE: usize = 1000;

/// One short line, with no number spelled out in dozens of digits.
fn assert_readable(line: &str, what: &str) {
    assert!(line.len() <= MAX_LINE, "{what}: a {}-byte line: {}…", line.len(), line.chars().take(300).collect::<String>());
    let mut run = 0;
    for c in line.chars() {
        run = if c.is_ascii_digit() { run + 1 } else { 0 };
        assert!(run < 30, "{what}: a number spelled out in digits: {}…", line.chars().take(300).collect::<String>());
    }
}

/// Every numeric field of the meter-out netlist (numbers, and texts that
/// start with a number such as "45 mm") set to each extreme float in turn:
/// `check` ends cleanly and every line it prints stays short and readable.
#[test]
fn extreme_floats_in_every_numeric_field_end_cleanly() {
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let text = std::fs::read_to_string(models.join("meter_out.json")).unwrap();
    let original: Value = serde_json::from_str(&text).unwrap();
    let dir = Scratch::new("extreme");
    std::fs::create_dir_all(dir.0.join("lib")).unwrap();
    std::fs::copy(models.join("lib/cylinder.json"), dir.0.join("lib/cylinder.json")).unwrap();
    let mut all = Vec::new();
    paths(&original, &mut Vec::new(), &mut all);
    let numeric = |v: &Value| v.is_number() || v.as_str().is_some_and(|s| s.trim_start().starts_with(|c: char| c.is_ascii_digit()));
    let mut runs = 0;
    for path in &all {
        for x in [1e300, -1e300, 5e-324] {
            let mut v = original.clone();
            let Some(parent) = parent_mut(&mut v, path) else { continue };
            let last = path.last().unwrap();
            let slot = match parent {
                Value::Object(m) => m.get_mut(last),
                Value::Array(a) => last.parse::<usize>().ok().and_then(|i| a.get_mut(i)),
                _ => None,
            };
            let Some(slot) = slot.filter(|s| numeric(s)) else { continue };
            *slot = match slot {
                // "45 mm" -> "1e300 mm": the number replaced, its unit kept
                Value::String(s) => match s.trim().split_once(' ') {
                    Some((_, unit)) => Value::from(format!("{x:e} {unit}")),
                    None => Value::from(x),
                },
                _ => Value::from(x),
            };
            std::fs::write(dir.0.join("extreme.json"), serde_json::to_vec_pretty(&v).unwrap()).unwrap();
            clean(&pneumo(&dir.0, &["check", "extreme.json"]), &format!("{} = {x:e}", path.join(".")));
            runs += 1;
        }
    }
    println!("{runs} runs of check with an extreme float");
    assert!(runs > 30, "only {runs} numeric fields found");
    Page::read("docs/reliability.md").says("--test mutants extreme_floats` |", &[Some(runs as f64)]);
}

#[test]
fn seeded_netlist_mutants_end_cleanly() {
    let n: usize = std::env::var("PNEUMO_MUTANTS").ok().and_then(|s| s.parse().ok()).unwrap_or(60);
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut sources: Vec<(String, String)> = std::fs::read_dir(&models)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap()))
        .collect();
    sources.sort();
    let dir = Scratch::new("mutants");
    // subsystems refer to lib/cylinder.json relative to the model
    std::fs::create_dir_all(dir.0.join("lib")).unwrap();
    std::fs::copy(models.join("lib/cylinder.json"), dir.0.join("lib/cylinder.json")).unwrap();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut ok_check, mut ok_sim) = (0, 0);
    for k in 0..n {
        let (name, text) = &sources[rng.below(sources.len())];
        let mut bytes = text.clone().into_bytes();
        if rng.below(4) == 0 {
            mutate_text(&mut bytes, &mut rng);
        } else {
            let mut v: Value = serde_json::from_str(text).unwrap();
            for _ in 0..1 + rng.below(3) {
                mutate_json(&mut v, &mut rng);
            }
            bytes = serde_json::to_vec_pretty(&v).unwrap();
        }
        let file = dir.0.join("mutant.json");
        std::fs::write(&file, &bytes).unwrap();
        let what = format!("mutant {k} of {name}");
        ok_check += clean(&pneumo(&dir.0, &["check", "mutant.json"]), &format!("{what}: check")) as usize;
        let out = dir.0.join("out.csv");
        let _ = std::fs::remove_file(&out);
        let sim = pneumo(&dir.0, &["simulate", "mutant.json", "--t-end", "0.3", "--out", "out.csv"]);
        let succeeded = clean(&sim, &format!("{what}: simulate"));
        ok_sim += succeeded as usize;
        if sim.status.code() == Some(1) || sim.status.code() == Some(2) {
            assert!(!out.exists(), "{what}: a failed simulate left out.csv");
        }
        let leftovers: Vec<_> = std::fs::read_dir(&dir.0)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|f| !matches!(f.as_str(), "mutant.json" | "out.csv" | "lib"))
            .collect();
        assert!(leftovers.is_empty(), "{what}: left behind {leftovers:?}");
    }
    println!("{n} mutants: {ok_check} passed check, {ok_sim} simulated; every other run ended with one error line");
    if std::env::var_os("PNEUMO_MUTANTS").is_none() {
        // the page's CI row: mutants, passed `check`, simulated (panics, hangs and bad lines fail above)
        let row = "| CI (every `cargo test`) | `cargo test -p pneumo-cli --test mutants` |";
        Page::read("docs/reliability.md").says(row, &[Some(n as f64), Some(ok_check as f64), Some(ok_sim as f64)]);
    }
    // the mutator must not be so destructive that nothing gets past the reader
    assert!(n < 20 || ok_check > 0, "no mutant passed check");
}

/// A discharge record as `pneumo conductance` reads it: 1 L from 6 bar
/// through a restriction, as a smooth decay (the fuzzer needs a plausible
/// file to mutate, not an exact one).
fn discharge_csv() -> String {
    let mut text = String::from("t,p,T\n");
    for i in 0..200 {
        let t = i as f64 * 0.01;
        let p = 1.013e5 + 5.0e5 * (-t / 0.6).exp();
        let temp = 293.15 - 30.0 * (-t / 0.6).exp() * (1.0 - (-t / 0.2).exp());
        text.push_str(&format!("{t:.3},{p:.1},{temp:.2}\n"));
    }
    text
}

/// One edit of a CSV record: a hostile cell, a dropped, duplicated or
/// swapped line, or a byte edit.
fn mutate_csv(text: &str, rng: &mut Rng) -> Vec<u8> {
    const CELLS: &[&str] = &["", "nan", "inf", "-1", "1e999", "abc", "\"", "1;2", "0x10", "\u{661}\u{662}", " 3 ", "-0"];
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let i = rng.below(lines.len());
    match rng.below(5) {
        0 => {
            let mut cells: Vec<String> = lines[i].split(',').map(str::to_string).collect();
            let k = rng.below(cells.len());
            cells[k] = CELLS[rng.below(CELLS.len())].to_string();
            lines[i] = cells.join(",");
        }
        1 => {
            lines.remove(i);
        }
        2 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        3 => {
            let j = rng.below(lines.len());
            lines.swap(i, j);
        }
        _ => {
            let mut bytes = lines.join("\n").into_bytes();
            mutate_text(&mut bytes, rng);
            return bytes;
        }
    }
    (lines.join("\n") + "\n").into_bytes()
}

#[test]
fn seeded_discharge_csv_mutants_end_cleanly() {
    let n: usize = std::env::var("PNEUMO_CSV_MUTANTS").ok().and_then(|s| s.parse().ok()).unwrap_or(30);
    let dir = Scratch::new("csv-mutants");
    let base = discharge_csv();
    let mut rng = Rng(0x5851_f42d_4c95_7f2d);
    let mut fitted = 0;
    for k in 0..n {
        let mut bytes = mutate_csv(&base, &mut rng);
        if rng.below(3) == 0 {
            bytes = mutate_csv(&String::from_utf8_lossy(&bytes), &mut rng);
        }
        std::fs::write(dir.0.join("d.csv"), &bytes).unwrap();
        let out = pneumo(&dir.0, &["conductance", "--volume", "1 L", "--data", "d.csv"]);
        fitted += clean(&out, &format!("csv mutant {k}")) as usize;
    }
    println!("{n} CSV mutants: {fitted} fitted; every other run ended with one error line");
    if std::env::var_os("PNEUMO_CSV_MUTANTS").is_none() {
        // the page's CI row of the discharge-record table: mutants, fitted
        let row = "| CI | `cargo test -p pneumo-cli --test mutants` |";
        Page::read("docs/reliability.md").says(row, &[Some(n as f64), Some(fitted as f64)]);
    }
}
