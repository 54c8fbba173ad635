//! Seeded mutants of the discrepancy manifest through its reader
//! (`manifest::parse`) and its resolution against the circuit and the data
//! files (`manifest::resolve`), in process: a valid manifest would start a
//! discrepancy run of tens of seconds through the command line, so the
//! reader is fuzzed here, below the command.
//!
//! Every mutant must give a manifest or an error; never a panic. An error is
//! one line free of control characters (the command prints it as is).
//! `PNEUMO_MANIFEST_MUTANTS` sets the count (default 300; the long run in
//! docs/reliability.md uses 20 000). The default run compares its counts
//! with that page's CI row.

use serde_json::Value;
use std::path::Path;

struct Files;
impl graph::Loader for Files {
    fn read(&self, path: &Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

/// xorshift64* (deterministic, no dependency).
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) % n.max(1) as u64) as usize
    }
}

const HOSTILE: &[&str] = &[
    "",
    "-1 s",
    "1e999 bar",
    "nan",
    "4 m",
    "= 1/0",
    "../../etc/passwd",
    "/dev/zero",
    "run1.csv\u{0}",
    "\u{1b}[2J",
    "head.p.p",
    "nobody.p",
    "7",
];

fn hostile(rng: &mut Rng) -> Value {
    match rng.below(6) {
        0 => Value::from(-1.0),
        1 => Value::Null,
        2 => serde_json::json!([]),
        3 => serde_json::json!({}),
        4 => Value::from(1e300),
        _ => Value::from(HOSTILE[rng.below(HOSTILE.len())]),
    }
}

/// Replace, delete or retype one entry somewhere in `v`.
fn mutate(v: &mut Value, rng: &mut Rng) {
    let stop = rng.below(4) == 0;
    match v {
        Value::Object(m) if !m.is_empty() => {
            let key = m.keys().nth(rng.below(m.len())).cloned().unwrap();
            let nested = m[&key].is_object() || m[&key].is_array();
            if nested && !stop {
                return mutate(m.get_mut(&key).unwrap(), rng);
            }
            match rng.below(3) {
                0 => {
                    m.remove(&key);
                }
                1 => {
                    m.insert(key, hostile(rng));
                }
                _ => {
                    m.insert(HOSTILE[rng.below(HOSTILE.len())].to_string(), hostile(rng));
                }
            }
        }
        Value::Array(a) if !a.is_empty() => {
            let i = rng.below(a.len());
            let nested = a[i].is_object() || a[i].is_array();
            if nested && !stop {
                return mutate(&mut a[i], rng);
            }
            match rng.below(3) {
                0 => {
                    a.remove(i);
                }
                1 => a[i] = hostile(rng),
                _ => {
                    let x = a[i].clone();
                    a.push(x);
                }
            }
        }
        other => *other = hostile(rng),
    }
}

fn one_clean_line(message: &str, what: &str) {
    assert!(!message.trim().is_empty(), "{what}: empty error message");
    assert!(!message.contains('\n'), "{what}: error on several lines:\n{message}");
    assert!(!message.chars().any(|c| c.is_control()), "{what}: control character in {message:?}");
}

#[test]
fn seeded_manifest_mutants_are_read_or_refused_cleanly() {
    let n: usize = std::env::var("PNEUMO_MANIFEST_MUTANTS").ok().and_then(|s| s.parse().ok()).unwrap_or(300);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let example = root.join("examples/discrepancy");
    let base: Value = serde_json::from_str(&std::fs::read_to_string(example.join("experiments.json")).unwrap()).unwrap();
    let flat = graph::load(&Files, &root.join("meter_out.json")).unwrap();
    // data files: the example's own, by bare name only (as the command allows)
    let read = |name: &str| -> Result<(String, String), String> {
        if name.is_empty() || name.contains('/') || name.contains('\\') || name.contains('\0') {
            return Err(format!("{name:?}: not a file in the manifest's folder"));
        }
        std::fs::read_to_string(example.join(name)).map(|t| (t, name.to_string())).map_err(|e| format!("{name:?}: {e}"))
    };
    let mut rng = Rng(0xd1b5_4a32_d192_ed03);
    let (mut parsed, mut resolved) = (0, 0);
    for k in 0..n {
        let mut v = base.clone();
        for _ in 0..1 + rng.below(3) {
            mutate(&mut v, &mut rng);
        }
        let text = serde_json::to_string_pretty(&v).unwrap();
        let what = format!("manifest mutant {k}");
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match identify::manifest::parse(&text, "experiments.json") {
                Err(e) => (false, false, Some(e.to_string())),
                Ok(m) => match identify::manifest::resolve(&m, &flat, &read) {
                    Ok(_) => (true, true, None),
                    Err(e) => (true, false, Some(e)),
                },
            }));
        let (p, r, message) = outcome.unwrap_or_else(|_| panic!("{what} panicked:\n{text}"));
        parsed += p as usize;
        resolved += r as usize;
        if let Some(m) = message {
            one_clean_line(&m, &what);
        }
    }
    println!("{n} manifest mutants: {parsed} parsed, {resolved} resolved; every other one refused with one clean line");
    assert!(n < 50 || resolved > 0, "the mutator never leaves a usable manifest");
    if std::env::var_os("PNEUMO_MANIFEST_MUTANTS").is_none() {
        // docs/reliability.md's CI row states these counts (whole numbers: compared exactly)
        let page = std::fs::read_to_string(root.join("../docs/reliability.md")).expect("docs/reliability.md");
        let row =
            page.lines().find(|l| l.starts_with("| CI | `cargo test -p pneumo-identify --test manifest_mutants` |")).expect("the CI row");
        let counts: Vec<usize> = row.split('|').filter_map(|cell| cell.trim().replace(' ', "").parse().ok()).collect();
        assert_eq!(
            counts[..3],
            [n, parsed, resolved],
            "docs/reliability.md is stale: its CI row {row:?} should read {n} | {parsed} | {resolved}"
        );
    }
}
