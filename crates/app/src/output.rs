//! Writing a command's outputs as one transaction: every output is written
//! to a temporary file beside its target, and only when all of them are
//! complete are they renamed into place; if anything fails, every temporary
//! is removed and every existing file is left byte for byte as it was. A
//! target that already exists is first moved aside (to a hidden backup in
//! its directory) so that a failing rename can put it back.
//!
//! Before anything is written, outputs are checked against the inputs and
//! against each other by file identity (canonical path, and device and inode
//! for files that exist): `--out` equal to the input netlist, to a data file,
//! or to `--summary` is refused with one line.
//!
//! A target that exists and is not a regular file (`/dev/null`,
//! `/dev/stdout`, a named pipe) is written in place after the renames:
//! renaming over it would replace the device by a regular file. A symbolic
//! link is followed, so the link stays a link.

use crate::error::AppError;
use solve::SimResult;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Where an output goes once the transaction commits.
#[derive(Debug)]
enum Staged {
    /// A regular file (new or existing): written to `tmp`, renamed onto `target`.
    File { target: PathBuf, tmp: PathBuf, shown: PathBuf },
    /// A device or pipe: written in place at commit.
    InPlace { target: PathBuf, bytes: Vec<u8>, shown: PathBuf },
}

/// The outputs of one command (see the module documentation).
#[derive(Debug, Default)]
pub struct Transaction {
    staged: Vec<Staged>,
    /// Identities of the files read (they must not be written).
    inputs: Vec<(PathBuf, FileIdentity)>,
}

/// What makes two paths the same file.
#[derive(Debug, Clone, PartialEq)]
struct FileIdentity {
    /// Canonical path (of the file, or of its directory joined with its name if it does not exist yet).
    path: PathBuf,
    /// (device, inode) of an existing file.
    node: Option<(u64, u64)>,
}

fn identity(path: &Path) -> Option<FileIdentity> {
    match std::fs::canonicalize(path) {
        Ok(real) => {
            #[cfg(unix)]
            let node = std::fs::metadata(&real).ok().map(|m| {
                use std::os::unix::fs::MetadataExt;
                (m.dev(), m.ino())
            });
            #[cfg(not(unix))]
            let node = None;
            Some(FileIdentity { path: real, node })
        }
        Err(_) => {
            let name = path.file_name()?;
            let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
            Some(FileIdentity { path: dir.join(name), node: None })
        }
    }
}

fn same(a: &FileIdentity, b: &FileIdentity) -> bool {
    a.path == b.path || (a.node.is_some() && a.node == b.node)
}

impl Transaction {
    /// A transaction for a command that reads `inputs` (netlists, data files).
    pub fn new(inputs: &[&Path]) -> Self {
        let inputs = inputs.iter().filter_map(|p| identity(p).map(|id| (p.to_path_buf(), id))).collect();
        Transaction { staged: Vec::new(), inputs }
    }

    /// Refuse outputs that are an input or each other, before any work is done.
    pub fn check_targets(&self, outputs: &[&Path]) -> Result<(), AppError> {
        let ids: Vec<(PathBuf, FileIdentity)> = outputs.iter().filter_map(|p| identity(p).map(|id| (p.to_path_buf(), id))).collect();
        for (k, (path, id)) in ids.iter().enumerate() {
            let device = std::fs::metadata(&id.path).map(|m| !m.is_file() && !m.is_dir()).unwrap_or(false);
            if device {
                continue; // writing /dev/null twice loses nothing
            }
            if let Some((input, _)) = self.inputs.iter().find(|(_, i)| same(i, id)) {
                return Err(AppError::Usage(format!(
                    "output {} is the input {}: refusing to overwrite it",
                    crate::error::shown_path(path),
                    crate::error::shown_path(input)
                )));
            }
            if let Some((other, _)) = ids[..k].iter().find(|(_, o)| same(o, id)) {
                return Err(AppError::Usage(format!(
                    "outputs {} and {} are the same file",
                    crate::error::shown_path(other),
                    crate::error::shown_path(path)
                )));
            }
        }
        Ok(())
    }

    /// Stage `bytes` for `path`: a regular target is written to a temporary now.
    pub fn add(&mut self, path: &Path, bytes: &[u8]) -> Result<(), AppError> {
        self.check_targets(&[path])?;
        if let Some(id) = identity(path) {
            let clash = self.staged.iter().any(|s| match s {
                Staged::File { shown, .. } => identity(shown).is_some_and(|o| same(&o, &id)),
                Staged::InPlace { .. } => false,
            });
            if clash {
                return Err(AppError::Usage(format!("{} would be written twice", crate::error::shown_path(path))));
            }
        }
        let target = match std::fs::canonicalize(path) {
            Ok(real) => {
                let meta = std::fs::metadata(&real).map_err(|e| AppError::io(path, e))?;
                if meta.is_dir() {
                    return Err(AppError::Usage(format!("{} is a directory, not a file", crate::error::shown_path(path))));
                }
                if !meta.is_file() {
                    self.staged.push(Staged::InPlace { target: real, bytes: bytes.to_vec(), shown: path.to_path_buf() });
                    return Ok(());
                }
                real
            }
            // Not there yet (or a dangling link): create it beside the given path.
            Err(_) => path.to_path_buf(),
        };
        let tmp = temporary_beside(&target, "tmp")
            .ok_or_else(|| AppError::Usage(format!("{} is not a file name", crate::error::shown_path(path))))?;
        let written = (|| {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_all()
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(AppError::io(path, e));
        }
        self.staged.push(Staged::File { target, tmp, shown: path.to_path_buf() });
        Ok(())
    }

    /// Put every staged output in place, or none of them.
    pub fn commit(mut self) -> Result<(), AppError> {
        let staged = std::mem::take(&mut self.staged);
        // 1. existing regular targets move aside
        let mut backups: Vec<(PathBuf, PathBuf)> = Vec::new();
        let mut failure: Option<AppError> = None;
        for s in &staged {
            if let Staged::File { target, shown, .. } = s {
                if std::fs::symlink_metadata(target).is_ok() {
                    let Some(backup) = temporary_beside(target, "old") else { continue };
                    match std::fs::rename(target, &backup) {
                        Ok(()) => backups.push((target.clone(), backup)),
                        Err(e) => {
                            failure = Some(AppError::io(shown, e));
                            break;
                        }
                    }
                }
            }
        }
        // 2. the new files move in
        let mut placed: Vec<PathBuf> = Vec::new();
        if failure.is_none() {
            for s in &staged {
                if let Staged::File { target, tmp, shown } = s {
                    match std::fs::rename(tmp, target) {
                        Ok(()) => placed.push(target.clone()),
                        Err(e) => {
                            failure = Some(AppError::io(shown, e));
                            break;
                        }
                    }
                }
            }
        }
        if let Some(e) = failure {
            // undo: remove what was placed and the temporaries, restore the originals
            for p in &placed {
                let _ = std::fs::remove_file(p);
            }
            for s in &staged {
                if let Staged::File { tmp, .. } = s {
                    let _ = std::fs::remove_file(tmp);
                }
            }
            for (target, backup) in &backups {
                let _ = std::fs::rename(backup, target);
            }
            return Err(e);
        }
        for (_, backup) in &backups {
            let _ = std::fs::remove_file(backup);
        }
        // 3. devices and pipes, in place
        for s in staged {
            if let Staged::InPlace { target, bytes, shown } = s {
                write_in_place(&target, &bytes).map_err(|e| AppError::io(&shown, e))?;
            }
        }
        Ok(())
    }
}

impl Drop for Transaction {
    /// A transaction dropped without a commit (an error on the way) leaves no temporary behind.
    fn drop(&mut self) {
        for s in &self.staged {
            if let Staged::File { tmp, .. } = s {
                let _ = std::fs::remove_file(tmp);
            }
        }
    }
}

/// A hidden temporary name in the directory of `target`, unique to this process.
fn temporary_beside(target: &Path, kind: &str) -> Option<PathBuf> {
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = target.file_name()?;
    Some(dir.join(format!(".{}.{kind}{}", name.to_string_lossy(), std::process::id())))
}

/// Write into an existing non-regular file (a device or a pipe) without creating anything.
fn write_in_place(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
    f.write_all(bytes)?;
    f.flush()
}

/// Names of the available signals listed in full when a name is unknown;
/// a larger circuit lists this many and the count.
pub const SIGNALS_LISTED: usize = 24;

/// "unknown signal" as one short line: the name escaped and shortened, the
/// nearest names, and the first [`SIGNALS_LISTED`] available signals.
pub fn unknown_signal(name: &str, available: &[String]) -> AppError {
    let near = blocks::suggest::did_you_mean(name, available.iter().map(String::as_str));
    let listed = available.iter().take(SIGNALS_LISTED).map(String::as_str).collect::<Vec<_>>().join(", ");
    let more = match available.len().checked_sub(SIGNALS_LISTED) {
        Some(rest) if rest > 0 => format!(", … and {rest} more ({} in all)", available.len()),
        _ => String::new(),
    };
    AppError::Usage(format!("unknown signal \"{}\"{near} (available: {listed}{more})", graph::escape(name)))
}

/// Columns to write: all, or the selection (each must exist).
pub fn select_columns(result: &SimResult, wanted: &[String]) -> Result<Vec<usize>, AppError> {
    if wanted.is_empty() {
        return Ok((0..result.columns.len()).collect());
    }
    wanted.iter().map(|w| result.column(w).ok_or_else(|| unknown_signal(w, &result.columns))).collect()
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

/// Summary JSON: cycles, signal ranges, balance residuals, solver statistics.
pub fn summary(result: &SimResult, model_name: &str, columns: &[usize]) -> serde_json::Value {
    use serde_json::json;
    // every cycle in the order completed, and the same listed per controller
    let mut numbers: Vec<(String, usize)> = Vec::new();
    let mut by_controller = serde_json::Map::new();
    let cycles: Vec<_> = result
        .cycles
        .iter()
        .map(|c| {
            let k = match numbers.iter_mut().find(|(id, _)| *id == c.controller) {
                Some((_, n)) => {
                    *n += 1;
                    *n
                }
                None => {
                    numbers.push((c.controller.clone(), 1));
                    1
                }
            };
            let entry = json!({"controller": c.controller, "cycle": k, "start_s": c.start, "extend_s": finite(c.extend),
                               "retract_s": finite(c.retract), "total_s": c.total});
            if let Some(list) = by_controller.entry(c.controller.clone()).or_insert_with(|| json!([])).as_array_mut() {
                list.push(entry.clone());
            }
            entry
        })
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
    // "n_mean" of every chamber, per stroke, one value per cycle (of each
    // controller, nested by controller id when there are several)
    let several = result.cycle_controllers.len() > 1;
    let mut polytropic = serde_json::Map::new();
    for st in result.stroke_statistics.iter().filter(|s| s.name == "n_mean") {
        let map = if several {
            match polytropic.entry(st.controller.clone()).or_insert_with(|| json!({})).as_object_mut() {
                Some(m) => m,
                None => continue,
            }
        } else {
            &mut polytropic
        };
        let entry = map.entry(st.id.clone()).or_insert_with(|| json!({"extend": [], "retract": []}));
        if let Some(list) = entry[st.stroke].as_array_mut() {
            list.push(json!(st.value));
        }
    }
    json!({
        "model": model_name,
        "t_final_s": result.t_final,
        "cycles": cycles,
        "cycles_by_controller": by_controller,
        "air_consumption": air_consumption(result),
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
            "linear_algebra": result.linear_algebra, "evaluations_per_jacobian": result.evaluations_per_jacobian,
            "jacobian": result.jacobian, "finite_difference_blocks": result.finite_difference_blocks,
            "events": result.events.len(), "samples": result.times.len()
        }
    })
}

/// A number for JSON, or null where it is undefined (a sequencer's strokes).
fn finite(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// Free air delivered by each supply [ANR L], over the run and per cycle of
/// each controller, with the mean flow [ANR L/min] (over the completed
/// cycles if there are any, else over the run).
pub fn air_consumption(result: &SimResult) -> serde_json::Value {
    use serde_json::json;
    let mut sources = serde_json::Map::new();
    for st in result.run_statistics.iter().filter(|s| s.name == "free_air") {
        let Some(total_m3) = st.value else { continue };
        let mut per_cycle = serde_json::Map::new();
        let mut per_cycle_rate = serde_json::Map::new();
        let (mut cycle_l, mut cycle_s) = (0.0, 0.0);
        for c in result.cycle_statistics.iter().filter(|c| c.name == "free_air" && c.id == st.id) {
            let Some(v) = c.value else { continue };
            let litres = v * 1e3;
            let duration = result.cycles_of(&c.controller).nth(c.cycle - 1).map_or(f64::NAN, |r| r.total);
            if let Some(list) = per_cycle.entry(c.controller.clone()).or_insert_with(|| json!([])).as_array_mut() {
                list.push(json!(litres));
            }
            if let Some(list) = per_cycle_rate.entry(c.controller.clone()).or_insert_with(|| json!([])).as_array_mut() {
                list.push(finite(litres / duration * 60.0));
            }
            if Some(&c.controller) == result.cycle_controllers.first() {
                cycle_l += litres;
                cycle_s += duration;
            }
        }
        let mean = if cycle_s > 0.0 { cycle_l / cycle_s * 60.0 } else { total_m3 * 1e3 / result.t_final * 60.0 };
        sources.insert(
            st.id.clone(),
            json!({
                "free_air_L": total_m3 * 1e3,
                "mean_L_per_min": finite(mean),
                "per_cycle_L": per_cycle,
                "per_cycle_L_per_min": per_cycle_rate
            }),
        );
    }
    json!({
        "reference": "free air (ANR) at the ISO 8778 standard reference atmosphere: 20 degC, 100 kPa, 65 % RH, 1.185 kg/m3",
        "sources": sources
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One output on its own (a transaction of one file).
    fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), AppError> {
        let mut t = Transaction::new(&[]);
        t.add(path, bytes)?;
        t.commit()
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect()
    }

    #[test]
    fn a_failing_output_leaves_every_existing_file_as_it_was() {
        let dir = scratch("rollback");
        let (a, b) = (dir.join("a.csv"), dir.join("b.json"));
        std::fs::write(&a, b"old a").unwrap();
        std::fs::write(&b, b"old b").unwrap();
        let mut t = Transaction::new(&[]);
        t.add(&a, b"new a").unwrap();
        // the second output's directory does not exist: staging fails ...
        assert!(t.add(&dir.join("missing/c.png"), b"c").is_err());
        drop(t);
        // ... and nothing was replaced, no temporary is left
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert_eq!(std::fs::read(&b).unwrap(), b"old b");
        assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
        // a complete transaction replaces both
        let mut t = Transaction::new(&[]);
        t.add(&a, b"new a").unwrap();
        t.add(&b, b"new b").unwrap();
        t.commit().unwrap();
        assert_eq!((std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap()), (b"new a".to_vec(), b"new b".to_vec()));
        assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_output_that_is_an_input_or_another_output_is_refused() {
        let dir = scratch("same");
        let model = dir.join("m.json");
        std::fs::write(&model, b"{}").unwrap();
        let t = Transaction::new(&[&model]);
        let e = t.check_targets(&[&dir.join("r.csv"), &model]).unwrap_err().to_string();
        assert!(e.contains("m.json") && e.contains("input"), "{e}");
        // the same file reached through another spelling
        let other = dir.join(".").join("m.json");
        assert!(t.check_targets(&[&other]).is_err());
        let e = t.check_targets(&[&dir.join("r.csv"), &dir.join("./r.csv")]).unwrap_err().to_string();
        assert!(e.contains("same file"), "{e}");
        #[cfg(unix)]
        {
            let link = dir.join("link.json");
            std::os::unix::fs::symlink(&model, &link).unwrap();
            assert!(t.check_targets(&[&link]).is_err(), "a link to the input is the input");
        }
        assert_eq!(std::fs::read(&model).unwrap(), b"{}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

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
