//! Writing result files atomically: to a temporary file beside the target,
//! renamed into place only when complete, so a failed run leaves no partial file.

use crate::error::CliError;
use solve::SimResult;
use std::io::Write;
use std::path::Path;

/// Write `bytes` to `path` through a temporary file and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| CliError::Usage(format!("{} is not a file name", path.display())))?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(CliError::io(path, e));
    }
    Ok(())
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
pub fn csv(result: &SimResult, columns: &[usize]) -> String {
    let mut s = String::with_capacity(result.rows.len() * (columns.len() + 1) * 14);
    s.push('t');
    for &c in columns {
        s.push(',');
        s.push_str(&result.columns[c]);
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
    json!({
        "model": model_name,
        "t_final_s": result.t_final,
        "cycles": cycles,
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
