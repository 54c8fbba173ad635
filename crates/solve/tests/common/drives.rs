//! A scalable test circuit: `n` meter-out drives on one supply, used by
//! `tests/jacobian.rs` and by the scaling benchmark `benches/drives.rs`
//! (included in both with `#[path]`, so it needs nothing from `common`).

use serde_json::{json, Value};

struct Files;
impl graph::Loader for Files {
    fn read(&self, path: &std::path::Path) -> Result<String, String> {
        std::fs::read_to_string(path).map_err(|e| e.to_string())
    }
}

/// `n` meter-out drives (5/2 valve, speed-control valve, cylinder, cycler)
/// on one supply line and manifold: the circuit of docs/performance.md's
/// scaling study. Each drive has its own cycler; with `staggered` the
/// strokes cycle through 450, 430, …, 310 mm so that the drives fall out of
/// step (every drive's events at its own instants), otherwise all drives are
/// alike and switch together.
pub fn drives(n: usize, staggered: bool) -> graph::FlatNetlist {
    drives_with_strokes(n, |i| if staggered { 450.0 - 20.0 * (i % 8) as f64 } else { 450.0 })
}

/// `n` drives as in [`drives`], drive `i` with a stroke of `stroke_mm(i)` mm
/// (the example `drives_scaling` gives every drive its own).
#[allow(dead_code)] // not every target that includes this file uses it
pub fn drives_with_strokes(n: usize, stroke_mm: impl Fn(usize) -> f64) -> graph::FlatNetlist {
    let cylinder = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lib/cylinder.json");
    let mut components = vec![
        json!({"id": "supply", "type": "pressure_source", "params": {"p": "6 bar", "T": "292 K"}}),
        json!({"id": "line", "type": "conductance", "params": {"C": "2000 L/min/bar", "b": 0.3}}),
        json!({"id": "manifold", "type": "chamber", "params": {"dead_volume": "2 L", "T_wall": "292 K"}}),
        json!({"id": "exhaust", "type": "atmosphere", "params": {"p": "0.98 bar", "T": "292 K"}}),
    ];
    let mut connections = vec![json!(["supply.port", "line.a"]), json!(["line.b", "manifold.port"])];
    for i in 0..n {
        let d = format!("d{i}");
        let stroke = format!("{} mm", stroke_mm(i));
        components.extend([
            json!({"id": format!("{d}_dcv"), "type": "valve_5_2", "params": {"C": "490 L/min/bar", "b": 0.3}}),
            json!({"id": format!("{d}_fc"), "type": "speed_control_valve",
                   "params": {"C": "13.2 L/min/bar", "b": 0.3, "check_C": "490 L/min/bar", "check_b": 0.3}}),
            json!({"id": format!("{d}_cyl"), "type": "subsystem", "file": cylinder.to_str().unwrap()}),
            json!({"id": format!("{d}_ctl"), "type": "cycler", "params": {"stroke": stroke}}),
        ]);
        connections.extend([
            json!(["manifold.port", format!("{d}_dcv.P")]),
            json!([format!("{d}_dcv.A"), format!("{d}_cyl.head_port")]),
            json!([format!("{d}_dcv.B"), format!("{d}_fc.a")]),
            json!([format!("{d}_fc.b"), format!("{d}_cyl.rod_port")]),
            json!([format!("{d}_dcv.EA"), "exhaust.port"]),
            json!([format!("{d}_dcv.EB"), "exhaust.port"]),
            json!({"from": format!("{d}_cyl.x"), "to": format!("{d}_ctl.x")}),
            json!({"from": format!("{d}_ctl.command"), "to": format!("{d}_dcv.command")}),
        ]);
    }
    let net: Value = json!({
        "name": format!("drives_{n}"), "components": components, "connections": connections,
        "simulation": {"t_end": "3 s", "rtol": 1e-4, "atol": 1e-4, "max_step": "250 ms", "initial": "rest"}
    });
    // one directory per call: tests in parallel build the same circuit
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("pneumo-jacobian-{}-{n}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drives.json");
    std::fs::write(&file, serde_json::to_string_pretty(&net).unwrap()).unwrap();
    let flat = graph::load(&Files, &file).unwrap_or_else(|e| panic!("load: {e}"));
    let _ = std::fs::remove_dir_all(&dir);
    flat
}
