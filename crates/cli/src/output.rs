//! Writing result files atomically: to a temporary file beside the target,
//! renamed into place only when complete, so a failed run leaves no partial file.
//! A target that exists and is not a regular file (`/dev/null`, `/dev/stdout`,
//! a named pipe) is written in place: renaming over it would replace the device
//! by a regular file. A symbolic link is followed, so the link stays a link.

use crate::error::CliError;
use solve::SimResult;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Write `bytes` to `path` through a temporary file and a rename, or in place
/// when `path` names something other than a regular file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let target = match std::fs::canonicalize(path) {
        Ok(real) => {
            let is_file = std::fs::metadata(&real).map_err(|e| CliError::io(path, e))?.is_file();
            if !is_file {
                return write_in_place(&real, bytes).map_err(|e| CliError::io(path, e));
            }
            real
        }
        // Not there yet (or a dangling link): create it beside the given path.
        Err(_) => path.to_path_buf(),
    };
    let tmp = temporary_beside(&target).ok_or_else(|| CliError::Usage(format!("{} is not a file name", path.display())))?;
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, &target)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(CliError::io(path, e));
    }
    Ok(())
}

/// A hidden temporary name in the directory of `target`, unique to this process.
fn temporary_beside(target: &Path) -> Option<PathBuf> {
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = target.file_name()?;
    Some(dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id())))
}

/// Write into an existing non-regular file (a device or a pipe) without creating anything.
fn write_in_place(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
    f.write_all(bytes)?;
    f.flush()
}

/// Columns to write: all, or the selection (each must exist).
pub fn select_columns(result: &SimResult, wanted: &[String]) -> Result<Vec<usize>, CliError> {
    if wanted.is_empty() {
        return Ok((0..result.columns.len()).collect());
    }
    wanted
        .iter()
        .map(|w| {
            result.column(w).ok_or_else(|| CliError::Usage(format!("unknown signal \"{w}\" (available: {})", result.columns.join(", "))))
        })
        .collect()
}

/// CSV text: header `t,<id>.<signal>...` in SI units; undefined values are empty cells.
pub fn csv(result: &SimResult, columns: &[usize], header_units: bool) -> String {
    let mut s = String::with_capacity(result.rows.len() * (columns.len() + 1) * 14);
    s.push_str(if header_units { "t [s]" } else { "t" });
    for &c in columns {
        s.push(',');
        s.push_str(&result.columns[c]);
        if header_units {
            let unit = if result.units[c].is_empty() { "1" } else { &result.units[c] };
            s.push_str(&format!(" [{unit}]"));
        }
    }
    s.push('\n');
    for (t, row) in result.times.iter().zip(&result.rows) {
        s.push_str(&format!("{t}"));
        for &c in columns {
            s.push(',');
            if let Some(v) = row[c] {
                s.push_str(&format!("{v}"));
            }
        }
        s.push('\n');
    }
    s
}

/// A CSV header cell "head.p [Pa]" as ("head.p", Some("Pa")); "head.p" as ("head.p", None).
pub fn split_header(cell: &str) -> (String, Option<String>) {
    let cell = cell.trim();
    match cell.strip_suffix(']').and_then(|c| c.rsplit_once(" [")) {
        Some((name, unit)) => (name.trim().to_string(), Some(unit.trim().to_string())),
        None => (cell.to_string(), None),
    }
}

/// Print warnings, one line each on stderr, without repeating a line.
pub fn print_warnings(warnings: &[graph::Warning]) {
    let mut seen = std::collections::BTreeSet::new();
    for w in warnings {
        if seen.insert(w) {
            eprintln!("warning: {w}");
        }
    }
}

/// Summary JSON: cycles, signal ranges, balance residuals, solver statistics.
pub fn summary(result: &SimResult, model_name: &str, columns: &[usize]) -> serde_json::Value {
    use serde_json::json;
    let cycles: Vec<_> = result
        .cycles
        .iter()
        .map(|c| json!({"start_s": c.start, "extend_s": c.extend, "retract_s": c.retract, "total_s": c.total}))
        .collect();
    let mut signals = serde_json::Map::new();
    for &c in columns {
        let vals = result.rows.iter().filter_map(|r| r[c]);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in vals {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo.is_finite() {
            signals.insert(result.columns[c].clone(), json!({"min": lo, "max": hi, "unit": result.units[c]}));
        }
    }
    let b = &result.balance;
    let rest: Vec<_> =
        result.rest.values.iter().map(|v| json!({"component": v.id, "param": v.param, "value": v.value, "reason": v.reason})).collect();
    let masses: Vec<_> = result
        .final_state
        .masses
        .iter()
        .map(|m| json!({"id": m.id, "mode": m.mode, "x_m": m.x, "v_m_s": m.v, "applied_N": m.applied, "breakaway_N": m.breakaway}))
        .collect();
    let pressures: serde_json::Map<String, serde_json::Value> =
        result.final_state.pressures.iter().map(|(id, p)| (format!("{id}.p"), json!(p))).collect();
    // "n_mean" of every chamber, per stroke, one value per cycle
    let mut polytropic = serde_json::Map::new();
    for st in result.stroke_statistics.iter().filter(|s| s.name == "n_mean") {
        let entry = polytropic.entry(st.id.clone()).or_insert_with(|| json!({"extend": [], "retract": []}));
        if let Some(list) = entry[st.stroke].as_array_mut() {
            list.push(json!(st.value));
        }
    }
    json!({
        "model": model_name,
        "t_final_s": result.t_final,
        "cycles": cycles,
        "mean_polytropic_index": polytropic,
        "initial_rest_state": rest,
        "final_state": {"masses": masses, "pressures_Pa": pressures},
        "signals": signals,
        "conservation": {
            "mass_initial_kg": b.mass_initial, "mass_final_kg": b.mass_final, "mass_in_kg": b.mass_in,
            "mass_residual": b.mass_residual,
            "energy_initial_J": b.energy_initial, "energy_final_J": b.energy_final, "energy_in_J": b.energy_in,
            "heat_in_J": b.heat_in, "work_out_J": b.work_out, "energy_residual": b.energy_residual
        },
        "solver": {
            "steps": result.stats.steps, "rejected": result.stats.rejected,
            "rhs_evaluations": result.rhs_evaluations, "jacobians": result.stats.jacobians,
            "events": result.events.len(), "samples": result.times.len()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("pneumo-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_new_file_is_written_and_no_temporary_is_left() {
        let dir = scratch("new");
        let out = dir.join("r.csv");
        write_atomic(&out, b"t\n0\n").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"t\n0\n");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("r.csv")]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_stays_a_link_and_its_target_is_replaced() {
        let dir = scratch("link");
        let real = dir.join("real.csv");
        let link = dir.join("link.csv");
        std::fs::write(&real, b"old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// `--out /dev/null` must not turn the device into a regular file (which
    /// happens to a rename when the writer may create files in /dev).
    #[cfg(unix)]
    #[test]
    fn a_device_is_written_in_place_and_stays_a_device() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        let is_device = |p: &Path| std::fs::metadata(p).map(|m| m.file_type().is_char_device()).unwrap_or(false);
        if !is_device(null) {
            eprintln!("skipped: /dev/null is not a character device on this machine");
            return;
        }
        write_atomic(null, b"discarded").unwrap();
        assert!(is_device(null), "/dev/null was replaced by a regular file");
    }
}
