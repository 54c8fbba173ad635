//! End-to-end tests of `pneumo discrepancy` on the shipped example
//! (models/examples/discrepancy: the meter-out circuit with a hidden piston
//! seal leak of 0.3 L/(min·bar)), in private temporary directories.
//!
//! Checked: the verdict names the leak and its conductance is recovered; the
//! report directory holds the augmented netlist (which `pneumo simulate`
//! runs, with a seal-leak conductance between the chambers), report.md with
//! its figures (PNG) and summary.json; `--json` prints the documented keys;
//! bad inputs end with one `error:` line naming the file, line and column.
//! To stay fast the happy path restricts the catalogue to two effects (the
//! full catalogue on this example is the benchmark, see docs/discrepancy.md).

mod common;

use common::{repo, Scratch, PNG_MAGIC};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

fn example() -> PathBuf {
    repo().join("models/examples/discrepancy")
}

fn pneumo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pneumo")).args(args).output().expect("run pneumo")
}

/// The shipped manifest with extra keys, written into `dir` with copies of
/// its data files (data must lie in the manifest's folder).
fn manifest_copy(dir: &Scratch, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(example().join("experiments.json")).expect("manifest");
    let mut v: Value = serde_json::from_str(&text).expect("json");
    for e in v["experiments"].as_array_mut().expect("experiments") {
        let name = e["data"].as_str().expect("data").to_string();
        dir.write(&name, &std::fs::read_to_string(example().join(&name)).expect("data file"));
    }
    let extra: Value = serde_json::from_str(extra).expect("extra json");
    for (k, x) in extra.as_object().expect("object") {
        v[k] = x.clone();
    }
    dir.write("experiments.json", &serde_json::to_string_pretty(&v).expect("json"))
}

#[test]
fn names_the_hidden_leak_and_writes_a_runnable_model_and_report() {
    let dir = Scratch::new("example");
    let manifest = manifest_copy(&dir, r#"{ "effects": ["piston_seal_leak", "valve_delay"], "max_effects": 1 }"#);
    let model = repo().join("models/meter_out.json");
    let report = dir.path("report");
    let out = pneumo(&[
        "discrepancy",
        model.to_str().unwrap(),
        "--experiments",
        manifest.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).expect("--json prints JSON");
    // the documented shape
    for key in ["baseline", "candidates", "selected", "after"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert!(v["baseline"]["rmse"]["head.p"].as_f64().is_some() && v["after"]["rmse"]["piston.x"].as_f64().is_some());
    for c in v["candidates"].as_array().expect("candidates") {
        assert!(c["effect"].is_string() && c["params"].is_object() && c.get("heldout_rmse").is_some() && c.get("delta_ic").is_some());
    }
    let selected = v["selected"].as_array().expect("selected");
    assert_eq!(selected.len(), 1, "{}", v["verdict"]);
    assert_eq!(selected[0]["effect"], "piston_seal_leak");
    let c = selected[0]["params"]["C"].as_f64().expect("C");
    assert!((c / (0.3 * L_MIN_BAR) - 1.0).abs() < 0.1, "C = {} L/min/bar", c / L_MIN_BAR);
    // the gap shrinks to the noise level
    for (ch, r) in v["after"]["rmse_normalized"].as_object().expect("rmse") {
        assert!(r.as_f64().unwrap() < 1.3, "{ch}: {r}");
    }
    assert!(v["baseline"]["rmse_normalized"]["piston.x"].as_f64().unwrap() > 5.0);
    // files
    for f in
        ["report.md", "summary.json", "residuals_by_phase.png", "fit_4bar_26.png", "fit_7bar_52.png", "model_with_piston_seal_leak.json"]
    {
        assert!(report.join(f).exists(), "{f} missing");
    }
    for f in ["residuals_by_phase.png", "fit_7bar_26.png"] {
        assert!(std::fs::read(report.join(f)).unwrap().starts_with(PNG_MAGIC), "{f}");
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(
        md.contains("missing effect: piston_seal_leak")
            && md.contains("![residuals per phase](residuals_by_phase.png)")
            && md.contains("95 %")
    );
    // the augmented netlist is a valid model with the leak between the chambers, and it runs
    let netlist: Value = serde_json::from_str(&std::fs::read_to_string(report.join("model_with_piston_seal_leak.json")).unwrap()).unwrap();
    let leak = netlist["components"].as_array().unwrap().iter().find(|c| c["type"] == "conductance").expect("leak component");
    let id = leak["id"].as_str().unwrap();
    let conns = netlist["connections"].to_string();
    assert!(conns.contains(&format!("{id}.a")) && conns.contains("head.port") && conns.contains("rod.port"));
    let sim = pneumo(&[
        "simulate",
        report.join("model_with_piston_seal_leak.json").to_str().unwrap(),
        "--cycles",
        "1",
        "--summary",
        dir.path("s.json").to_str().unwrap(),
    ]);
    assert!(sim.status.success(), "{}", String::from_utf8_lossy(&sim.stderr));
    // it is the user's netlist (parameters block, expressions) and loads without a warning
    assert_eq!(netlist["parameters"]["bore"]["value"], "45 mm");
    let head = netlist["components"].as_array().unwrap().iter().find(|c| c["id"] == "head").expect("head");
    assert_eq!(head["params"]["bore"], "= bore");
    let check = pneumo(&["check", report.join("model_with_piston_seal_leak.json").to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&check.stderr);
    assert!(check.status.success() && !stderr.to_lowercase().contains("warning"), "{stderr}");
    // no stray temporary files
    let stray: Vec<_> =
        std::fs::read_dir(&report).unwrap().filter_map(|e| e.ok()).filter(|e| e.file_name().to_string_lossy().starts_with('.')).collect();
    assert!(stray.is_empty());
}

fn one_error_line(out: &Output) -> String {
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    lines[0].to_string()
}

#[test]
fn a_malformed_data_file_is_named_with_line_and_column() {
    let dir = Scratch::new("bad-csv");
    dir.write("bad.csv", "t,p1_Pa,p2_Pa,x_m\n0,1e5,4e5,0\n0.001,1e5,4e5,0\n0.002,1e5,x4e5,0\n");
    let manifest = dir.write(
        "m.json",
        r#"{ "experiments": [ { "data": "bad.csv", "columns": { "p1_Pa": "head.p", "p2_Pa": "rod.p", "x_m": "piston.x" } } ] }"#,
    );
    let model = repo().join("models/meter_out.json");
    let e = one_error_line(&pneumo(&["discrepancy", model.to_str().unwrap(), "--experiments", manifest.to_str().unwrap()]));
    assert!(e.contains("bad.csv:4") && e.contains("column 3") && e.contains("p2_Pa") && e.contains("x4e5"), "{e}");
}

#[test]
fn bad_manifests_and_signals_are_clear_errors() {
    let dir = Scratch::new("bad-manifest");
    let model = repo().join("models/meter_out.json");
    let run = |m: &Path| one_error_line(&pneumo(&["discrepancy", model.to_str().unwrap(), "--experiments", m.to_str().unwrap()]));
    // unknown key, with file:line:column
    let m = dir.write("m1.json", "{\n  \"experiments\": [ { \"data\": \"a.csv\", \"sett\": {} } ]\n}\n");
    let e = run(&m);
    assert!(e.contains("m1.json:2:") && e.contains("sett"), "{e}");
    // a column mapped to a signal the model does not have
    dir.write("a.csv", &(0..20).fold(String::from("t,p\n"), |s, i| s + &format!("{},{}\n", i as f64 * 1e-3, 1e5 + i as f64)));
    let m = dir.write("m2.json", r#"{ "experiments": [ { "data": "a.csv", "columns": { "p": "head.pressure" } } ] }"#);
    let e = run(&m);
    assert!(e.contains("head.pressure") && e.contains("head.p"), "{e}");
    // a missing data file
    let m = dir.write("m3.json", r#"{ "experiments": [ { "data": "nowhere.csv" } ] }"#);
    assert!(run(&m).contains("nowhere.csv"));
    // an unknown effect
    let m = dir.write("m4.json", r#"{ "experiments": [ { "data": "a.csv", "columns": { "p": "head.p" } } ], "effects": ["gremlins"] }"#);
    let e = run(&m);
    assert!(e.contains("gremlins") && e.contains("piston_seal_leak"), "{e}");
    // missing --experiments
    let e = one_error_line(&pneumo(&["discrepancy", model.to_str().unwrap()]));
    assert!(e.contains("--experiments"), "{e}");
}
