//! One run written as CSV traces, a JSON summary and a plot (`pneumo
//! simulate`), and the summary of a run for any front end (Python's
//! `Result.summary`).

use crate::error::AppError;
use crate::load::netlist_with_files;
use crate::output::{csv, select_columns, summary, Transaction};
use crate::run::{execute, prepare, Run, RunSpec};
use std::fmt::Write;
use std::path::PathBuf;

/// One run and what to write (`pneumo simulate`).
#[derive(Debug, Clone, Default)]
pub struct SimulateOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Overrides `ID.PARAM=VALUE` (e.g. "flow_control.C=13.2 L/min/bar"), applied in order.
    pub sets: Vec<String>,
    /// Number of actuator cycles to run.
    pub cycles: Option<u64>,
    /// End time [s].
    pub t_end: Option<f64>,
    /// Write time traces (CSV, SI units).
    pub out: Option<PathBuf>,
    /// Write the summary (JSON).
    pub summary: Option<PathBuf>,
    /// Plot the written signals (PNG or SVG by extension).
    pub plot: Option<PathBuf>,
    /// Write each column's SI unit in the CSV header ("head.p [Pa]").
    pub header_units: bool,
    /// Signals to write (empty: the netlist's outputs, or all).
    pub signals: Vec<String>,
}

/// The `--summary` JSON of a run: every signal, and why the run is
/// incomplete if it is.
pub fn summary_of(r: &Run) -> serde_json::Value {
    let all: Vec<usize> = (0..r.result.columns.len()).collect();
    let mut s = summary(&r.result, &r.name, &all);
    if let Some(why) = &r.incomplete {
        s["incomplete"] = serde_json::json!(why);
    }
    s
}

/// Run the netlist of `o` and write its outputs, all or none; `warn`
/// receives the circuit's warnings before the run starts. A run that
/// reaches its end time before completing its cycles is returned with its
/// outputs written and [`Run::incomplete`] set: a front end reports it
/// (the command line exits with [`AppError::EXIT_INCOMPLETE`]).
pub fn simulate(o: &SimulateOptions, warn: &mut dyn FnMut(&[graph::Warning])) -> Result<Run, AppError> {
    let spec = RunSpec { sets: o.sets.clone(), cycles: o.cycles, t_end: o.t_end, cancel: None };
    let (flat, inputs) = netlist_with_files(&o.model, &[])?;
    let inputs: Vec<&std::path::Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = Transaction::new(&inputs);
    let targets: Vec<&std::path::Path> = [&o.out, &o.summary, &o.plot].into_iter().flatten().map(|p| p.as_path()).collect();
    outputs.check_targets(&targets)?;
    let mut prepared = prepare(flat, &spec)?;
    if o.out.is_none() && o.plot.is_none() {
        // no trace asked for: the summary's signal ranges come from the
        // integrator's own steps, not from a fine sampling grid
        prepared.opts.sample_interval = 0.0;
        prepared.opts.record_steps = true;
    }
    let wanted = if o.signals.is_empty() { prepared.outputs.clone() } else { o.signals.clone() };
    // unknown signal names are reported before the run, not after it
    let names = prepared.model.output_names();
    if let Some(bad) = wanted.iter().find(|w| !names.contains(w)) {
        return Err(crate::output::unknown_signal(bad, &names));
    }
    warn(&prepared.warnings);
    let r = execute(prepared)?;
    let columns = select_columns(&r.result, &wanted)?;
    // build everything before writing anything
    let csv_text = o.out.as_ref().map(|_| csv(&r.result, &columns, o.header_units));
    let summary_text = o.summary.as_ref().map(|_| serde_json::to_string_pretty(&summary_of(&r)).unwrap_or_default());
    let plot_bytes = match &o.plot {
        Some(path) => {
            let t0 = r.result.times.first().copied().unwrap_or(0.0);
            let title = crate::plot::run_title(&r.name, &o.sets, t0, r.result.t_final);
            Some(crate::plot::traces_image(&r.result, &columns, path, Some(&title))?)
        }
        None => None,
    };
    if let (Some(path), Some(bytes)) = (&o.plot, plot_bytes) {
        outputs.add(path, &bytes)?;
    }
    if let (Some(path), Some(text)) = (&o.out, csv_text) {
        outputs.add(path, text.as_bytes())?;
    }
    if let (Some(path), Some(text)) = (&o.summary, summary_text) {
        outputs.add(path, text.as_bytes())?;
    }
    outputs.commit()?;
    Ok(r)
}

/// What `pneumo simulate` prints after a run: the cycle times and mean
/// polytropic indices, the free air of every supply, the solver's work and
/// the balance residuals.
pub fn run_text(r: &Run) -> String {
    let mut text = String::new();
    let res = &r.result;
    let several = res.cycle_controllers.len() > 1;
    for controller in &res.cycle_controllers {
        for (i, c) in res.cycles_of(controller).enumerate() {
            let who = if several { format!("{controller} ") } else { String::new() };
            if c.extend.is_finite() {
                let _ =
                    writeln!(text, "{who}cycle {}: extend {:.4} s, retract {:.4} s, total {:.4} s", i + 1, c.extend, c.retract, c.total);
            } else {
                let _ = writeln!(text, "{who}cycle {}: total {:.4} s", i + 1, c.total);
            }
            let n: Vec<String> = res
                .stroke_statistics
                .iter()
                .filter(|s| &s.controller == controller && s.cycle == i + 1 && s.name == "n_mean")
                .map(|s| format!("{} {} {}", s.id, s.stroke, s.value.map_or("-".to_string(), |v| format!("{v:.3}"))))
                .collect();
            if !n.is_empty() {
                let _ = writeln!(text, "  mean polytropic index: {}", n.join(", "));
            }
        }
    }
    let air = crate::output::air_consumption(res);
    if let Some(sources) = air["sources"].as_object() {
        for (id, s) in sources {
            let per_cycle =
                s["per_cycle_L"].as_object().and_then(|m| m.values().next()).and_then(|l| l.as_array()).cloned().unwrap_or_default();
            let mean_cycle =
                (!per_cycle.is_empty()).then(|| per_cycle.iter().filter_map(|v| v.as_f64()).sum::<f64>() / per_cycle.len() as f64);
            let _ = writeln!(
                text,
                "{id}: free air {:.3} L ANR{}, {:.2} L/min ANR (ISO 8778)",
                s["free_air_L"].as_f64().unwrap_or(f64::NAN),
                mean_cycle.map_or(String::new(), |v| format!(" ({v:.3} L per cycle)")),
                s["mean_L_per_min"].as_f64().unwrap_or(f64::NAN)
            );
        }
    }
    let _ = writeln!(
        text,
        "t = {:.4} s, {} steps ({} rejected), {} evaluations, mass balance residual {:.1e}, energy residual {:.1e}",
        res.t_final, res.stats.steps, res.stats.rejected, res.rhs_evaluations, res.balance.mass_residual, res.balance.energy_residual
    );
    text
}
