//! End-to-end tests of `pneumo sweep` and `pneumo merge`, running the binary on
//! the paper's meter-out circuit (models/meter_out.json).
//!
//! The main study is the paper's Table 1 conductances × {4, 7} bar supply: 8
//! cases of 3 cycles. Checked: byte-identical output for 1 and 2 worker
//! threads; merged shards byte-identical to the unsharded file (CSV and JSON);
//! SI conversion of the varied values (hand-computed); case ordering; the
//! cycle time falling as the throttle opens; agreement, to the last digit,
//! with `pneumo simulate` for the same case; failed cases as error rows; and
//! one-line errors for bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const C_VALUES: &str = "flow_control.C=1.41 L/min/bar, 2.68 L/min/bar,13.2 L/min/bar ,210 L/min/bar";
const P_VALUES: &str = "supply.p=4 bar,7 bar";

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/meter_out.json")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pneumo-sweep-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

fn pneumo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pneumo")).args(args).output().expect("run pneumo")
}

fn ok(args: &[&str]) -> Output {
    let out = pneumo(args);
    assert!(out.status.success(), "pneumo {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    out
}

fn table_sweep(jobs: &str, extra: &[&str], out: &Path) -> Output {
    let m = model();
    let mut args = vec![
        "sweep",
        m.to_str().unwrap(),
        "--vary",
        C_VALUES,
        "--vary",
        P_VALUES,
        "--cycles",
        "3",
        "--jobs",
        jobs,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ok(&args)
}

/// Header and rows of a CSV file.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(path).expect("csv");
    let header = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r.records().map(|rec| rec.unwrap().iter().map(str::to_string).collect()).collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

fn num(s: &str) -> f64 {
    s.parse().unwrap_or_else(|_| panic!("not a number: {s:?}"))
}

/// Error message of one-line failures: non-zero exit, a single stderr line.
fn one_line_error(out: &Output) -> String {
    assert!(!out.status.success(), "expected failure");
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(err.trim_end().lines().count(), 1, "stderr: {err}");
    assert!(err.starts_with("error: "), "stderr: {err}");
    err
}

#[test]
fn table1_study_is_deterministic_shardable_and_physical() {
    let dir = scratch("table1");
    let (j1, j2) = (dir.join("j1.csv"), dir.join("j2.csv"));
    let stdout = table_sweep("1", &[], &j1);
    table_sweep("2", &[], &j2);
    let bytes = std::fs::read(&j1).unwrap();
    assert_eq!(bytes, std::fs::read(&j2).unwrap(), "--jobs 1 and --jobs 2 differ");

    let (h, rows) = read_csv(&j1);
    assert_eq!(rows.len(), 8);
    let (c, p, ct, err) = (col(&h, "flow_control.C"), col(&h, "supply.p"), col(&h, "cycle_time_s"), col(&h, "error"));
    // SI values by hand: 1 L/min/bar = 1e-3 m3 / 60 s / 1e5 Pa
    let c_si: Vec<f64> = [1.41, 2.68, 13.2, 210.0].iter().map(|x| x * 1e-3 / 60.0 / 1e5).collect();
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(num(&row[col(&h, "case")]), i as f64);
        assert_eq!(num(&row[col(&h, "n_cases")]), 8.0);
        assert!(row[err].is_empty(), "case {i} failed: {}", row[err]);
        let want_c = c_si[i / 2];
        assert!((num(&row[c]) - want_c).abs() <= 1e-12 * want_c, "case {i}: C = {}", row[c]);
        assert_eq!(num(&row[p]), [4e5, 7e5][i % 2]);
        // cycle_time_s is the last (3rd) cycle; each total = extend + retract + dwell >= extend + retract
        assert_eq!(row[ct], row[col(&h, "cycle3_total_s")]);
        for k in 1..=3 {
            let e = num(&row[col(&h, &format!("cycle{k}_extend_s"))]);
            let r = num(&row[col(&h, &format!("cycle{k}_retract_s"))]);
            let t = num(&row[col(&h, &format!("cycle{k}_total_s"))]);
            assert!(e > 0.0 && r > 0.0 && t >= e + r - 1e-9, "case {i} cycle {k}: {e} {r} {t}");
        }
        for ch in ["head", "rod"] {
            let lo = num(&row[col(&h, &format!("{ch}.T_min_K"))]);
            let hi = num(&row[col(&h, &format!("{ch}.T_max_K"))]);
            // the chambers start at 292 K, so the range must contain it
            assert!(lo <= 292.0 + 1e-9 && hi >= 292.0 - 1e-9 && lo < hi, "case {i} {ch}: {lo}..{hi}");
        }
    }
    // meter-out: opening the throttle shortens the cycle, at both pressures
    for pi in 0..2 {
        let times: Vec<f64> = (0..4).map(|ci| num(&rows[2 * ci + pi][ct])).collect();
        assert!(times.windows(2).all(|w| w[1] < w[0]), "p index {pi}: {times:?}");
    }
    let text = String::from_utf8_lossy(&stdout.stdout);
    assert!(text.contains("13.2 L/min/bar") && text.contains("8 cases") && text.contains("0 failed"), "{text}");

    // the same case through `pneumo simulate` gives the same numbers exactly
    let (traces, summary) = (dir.join("case4.csv"), dir.join("case4.json"));
    let m = model();
    ok(&[
        "simulate",
        m.to_str().unwrap(),
        "--set",
        "flow_control.C=13.2 L/min/bar",
        "--set",
        "supply.p=4 bar",
        "--cycles",
        "3",
        "--signals",
        "head.T,rod.T",
        "--out",
        traces.to_str().unwrap(),
        "--summary",
        summary.to_str().unwrap(),
    ]);
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    let row = &rows[4];
    for k in 0..3 {
        let total = s["cycles"][k]["total_s"].as_f64().unwrap();
        assert_eq!(num(&row[col(&h, &format!("cycle{}_total_s", k + 1))]), total);
    }
    let (th, trows) = read_csv(&traces);
    for ch in ["head", "rod"] {
        let tc = col(&th, &format!("{ch}.T"));
        let vals: Vec<f64> = trows.iter().filter(|r| !r[tc].is_empty()).map(|r| num(&r[tc])).collect();
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(num(&row[col(&h, &format!("{ch}.T_min_K"))]), lo);
        assert_eq!(num(&row[col(&h, &format!("{ch}.T_max_K"))]), hi);
    }

    // shards 1/2 + 2/2, merged (given in reverse order), equal the unsharded file
    let (s1, s2, merged) = (dir.join("s1.csv"), dir.join("s2.json"), dir.join("all.csv"));
    table_sweep("2", &["--shard", "1/2"], &s1);
    table_sweep("2", &["--shard", "2/2"], &s2);
    let (_, r1) = read_csv(&s1);
    // shard 1/2 holds the even cases (index mod 2 = 0), each knowing the sweep has 8
    assert_eq!(r1.iter().map(|r| num(&r[0])).collect::<Vec<_>>(), [0.0, 2.0, 4.0, 6.0]);
    assert!(r1.iter().all(|r| num(&r[1]) == 8.0));
    ok(&["merge", s2.to_str().unwrap(), s1.to_str().unwrap(), "--out", merged.to_str().unwrap()]);
    assert_eq!(std::fs::read(&merged).unwrap(), bytes, "merged shards differ from the unsharded output");
    // and to JSON: the same values as a direct JSON sweep of shard 2, case by case
    let mj = dir.join("all.json");
    ok(&["merge", s1.to_str().unwrap(), s2.to_str().unwrap(), "--out", mj.to_str().unwrap()]);
    let all: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&mj).unwrap()).unwrap();
    let shard2: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&s2).unwrap()).unwrap();
    let cases = all["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 8);
    for (k, case) in shard2["cases"].as_array().unwrap().iter().enumerate() {
        assert_eq!(&cases[2 * k + 1], case);
    }
    // merging the JSON back to CSV still reproduces the original bytes
    let back = dir.join("back.csv");
    ok(&["merge", mj.to_str().unwrap(), "--out", back.to_str().unwrap()]);
    assert_eq!(std::fs::read(&back).unwrap(), bytes);

    // a shard given twice, and a shard left out, are named
    let dup = one_line_error(&pneumo(&["merge", s1.to_str().unwrap(), s1.to_str().unwrap(), "--out", merged.to_str().unwrap()]));
    assert!(dup.contains("case 0 appears twice"), "{dup}");
    let gap = one_line_error(&pneumo(&["merge", s1.to_str().unwrap(), "--out", merged.to_str().unwrap()]));
    assert!(gap.contains("4 of 8 cases missing: 1, 3, 5, 7"), "{gap}");
    assert_eq!(std::fs::read(&merged).unwrap(), bytes, "a failed merge must not touch the output");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stalling_case_is_an_error_row_and_the_others_run() {
    let dir = scratch("stall");
    let out = dir.join("s.csv");
    let m = model();
    let run = ok(&[
        "sweep",
        m.to_str().unwrap(),
        "--vary",
        "supply.p=1 bar,4 bar",
        "--set",
        "flow_control.C=210 L/min/bar",
        "--cycles",
        "2",
        "--t-end",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (h, rows) = read_csv(&out);
    assert_eq!(rows.len(), 2);
    let err = col(&h, "error");
    // 1 bar against a 0.98 bar exhaust cannot overcome the 10 N static friction
    assert!(rows[0][err].contains("0 of 2 cycles"), "{:?}", rows[0]);
    for (i, cell) in rows[0].iter().enumerate() {
        // no cycle numbers and no temperature ranges (its parameters are still recorded)
        if h[i].starts_with("cycle") || h[i].ends_with("_K") {
            assert!(cell.is_empty(), "failed case has a number in {}", h[i]);
        }
    }
    assert!(rows[1][err].is_empty(), "{}", rows[1][err]);
    assert!(num(&rows[1][col(&h, "cycle_time_s")]) > 0.0);
    assert_eq!(num(&rows[0][col(&h, "supply.p")]), 1e5);
    assert!(String::from_utf8_lossy(&run.stdout).contains("1 failed"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_fails_before_running_with_one_line() {
    let dir = scratch("bad");
    let out = dir.join("never.csv");
    let m = model();
    let m = m.to_str().unwrap();
    let o = out.to_str().unwrap();
    let cases: [(&[&str], &str); 9] = [
        (&["--vary", "supply.p 4 bar,7 bar"], "expected ID.PARAM=V1,V2"),
        (&["--vary", "supply.p=4 bar,,7 bar"], "empty value"),
        (&["--vary", "suply.p=4 bar"], "no component \"suply\""),
        (&["--vary", "supply.pressure=4 bar"], "no parameter \"pressure\""),
        (&["--vary", "supply.p=4 bar,7 m"], "7 m"),
        (&["--vary", "supply.p=4 bar", "--shard", "3/2"], "--shard"),
        (&["--vary", "supply.p=4 bar", "--jobs", "0"], "--jobs"),
        (&["--vary", "gas.model=ideal,vdw"], "\"vdw\": expected one of ideal, semi_perfect, real"),
        (&["--vary", "gas.density=1"], "unknown gas setting \"density\""),
    ];
    for (extra, expect) in cases {
        let mut args = vec!["sweep", m, "--out", o];
        args.extend_from_slice(extra);
        let err = one_line_error(&pneumo(&args));
        assert!(err.contains(expect), "{extra:?}: {err}");
        assert!(!out.exists(), "{extra:?} wrote an output file");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_gas_model_can_be_swept() {
    let dir = scratch("gas");
    let out = dir.join("gas.csv");
    let m = model();
    ok(&["sweep", m.to_str().unwrap(), "--vary", "gas.model=ideal,REAL", "--cycles", "1", "--out", out.to_str().unwrap()]);
    let (header, rows) = read_csv(&out);
    let (g, t) = (col(&header, "gas.model"), col(&header, "cycle1_total_s"));
    assert_eq!(rows.iter().map(|r| r[g].as_str()).collect::<Vec<_>>(), ["ideal", "real"]);
    // The same case through `pneumo simulate`: identical cycle time.
    let summary = dir.join("real.json");
    ok(&["simulate", m.to_str().unwrap(), "--cycles", "1", "--set", "gas.model=real", "--summary", summary.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    assert_eq!(num(&rows[1][t]), v["cycles"][0]["total_s"].as_f64().unwrap());
    assert_ne!(num(&rows[0][t]), num(&rows[1][t]));
    let _ = std::fs::remove_dir_all(&dir);
}
