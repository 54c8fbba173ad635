//! `pneumo discrepancy` with an effect the user declares in the manifest
//! (`user_effects`, docs/discrepancy.md "Effects you declare"), end to end
//! through the command line, on data pneumo did not make.
//!
//! The data: the independent rig (`pneumo-rig`, through the truth module of
//! `crates/identify/tests`) with a hidden piston-seal leak following ISO 6358
//! with b = 0.5 (seed 4), two cycles at the four operating points — the
//! recipe of `crates/identify/tests/user_effects.rs`. The manifest sets only
//! `supply.p` and the throttle, declares the leak as a `conductance` between
//! the chambers with its C free, and leaves the built-in `piston_seal_leak`
//! out of the pool (the same physics twice would rightly end "ambiguous");
//! `dead_volume` and `valve_delay` compete with it.
//!
//! Stated up front: the JSON names the declared effect alone, and its fitted
//! C lies within ±30 % of the truth (the tolerance of
//! `crates/identify/tests/independent.rs`: the rig's exact check valve,
//! missing laminar region and exact stick–slip bias the estimate).

mod common;
#[path = "../../identify/tests/truth/mod.rs"]
mod truth;

use common::{repo, Scratch};
use serde_json::Value;
use std::process::Command;
use truth::{Case, Variation};

const L_MIN_BAR: f64 = 1e-3 / 60.0 / 1e5;

#[test]
fn a_declared_seal_leak_is_named_and_sized_from_the_command_line() {
    let seed = 4;
    let t = truth::draw(Case::Leak, seed, Variation::Nominal);
    let Some(rig::LeakLaw::Iso(leak)) = t.effects.seal_leak else { panic!("seed 4 draws an ISO leak: {}", t.description) };
    let records = truth::records(&t, seed, 2).expect("the rig simulates");
    let dir = Scratch::new("user-effect");
    for r in &records {
        let file = std::fs::File::create(dir.path(&format!("{}.csv", r.name))).expect("create the data file");
        rig::sensors::write_csv(&r.measured, std::io::BufWriter::new(file)).expect("write the data file");
    }
    let mut manifest: Value = serde_json::from_str(&truth::manifest_text(&records, &t.description)).expect("the manifest is JSON");
    manifest["effects"] = serde_json::json!(["dead_volume", "valve_delay"]);
    manifest["user_effects"] = Value::Array(vec![serde_json::from_str(truth::SEAL_ORIFICE).expect("the declaration is JSON")]);
    let manifest = dir.write("E.json", &serde_json::to_string_pretty(&manifest).expect("JSON"));
    let model = repo().join("models/meter_out.json");
    let out = Command::new(env!("CARGO_BIN_EXE_pneumo"))
        .args(["discrepancy", model.to_str().unwrap(), "--experiments", manifest.to_str().unwrap(), "--json"])
        .output()
        .expect("run pneumo");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).expect("--json prints JSON");
    let selected: Vec<&str> = v["selected"].as_array().expect("selected").iter().map(|s| s["effect"].as_str().expect("effect")).collect();
    assert_eq!(selected, ["seal_orifice"], "{}: verdict {}", t.description, v["verdict"]);
    let c = v["selected"][0]["params"]["seal.C"].as_f64().expect("the declared parameter is reported under its own name");
    eprintln!("seal.C fitted {:.4} L/min/bar, truth {:.4} L/min/bar", c / L_MIN_BAR, leak.c / L_MIN_BAR);
    assert!((c - leak.c).abs() <= 0.3 * leak.c, "C {:.4} L/min/bar, truth {:.4} L/min/bar", c / L_MIN_BAR, leak.c / L_MIN_BAR);
    // the declared effect was judged like the built-ins beside it
    let tried: Vec<&str> = v["candidates"].as_array().expect("candidates").iter().map(|c| c["effect"].as_str().expect("effect")).collect();
    for name in ["seal_orifice", "dead_volume", "valve_delay"] {
        assert!(tried.contains(&name), "{name} was not tried: {tried:?}");
    }
}
