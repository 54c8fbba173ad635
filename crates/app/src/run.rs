//! Running one simulation from a netlist with overrides: shared by
//! `simulate`, `sweep` and the Python package.

use crate::error::AppError;
use graph::FlatNetlist;

/// Inputs of one run besides the netlist file.
#[derive(Debug, Clone, Default)]
pub struct RunSpec {
    pub sets: Vec<String>,
    pub cycles: Option<u64>,
    pub t_end: Option<f64>,
    /// Stops the run early when raised (Ctrl-C in Python); the command line never raises it.
    pub cancel: Option<solve::Cancel>,
}

/// A finished run with the names the user asked to write.
pub struct Run {
    pub name: String,
    pub result: solve::SimResult,
    /// Why the run did less than asked (cycles not completed by the end
    /// time), with where the actuator stalled; its results are still valid.
    pub incomplete: Option<String>,
}

/// Run a netlist already loaded and expanded (`spec.sets` are
/// applied to it first); lets `sweep` read the file once for all cases.
pub fn run_flat(flat: FlatNetlist, spec: &RunSpec) -> Result<Run, AppError> {
    execute(prepare(flat, spec)?)
}

/// A model built and ready to run, with its settings.
pub struct Prepared {
    pub name: String,
    pub outputs: Vec<String>,
    pub model: solve::Model,
    pub opts: solve::SimOptions,
    pub warnings: Vec<graph::Warning>,
}

/// Apply overrides, build the circuit and settle the run settings.
pub fn prepare(mut flat: FlatNetlist, spec: &RunSpec) -> Result<Prepared, AppError> {
    if spec.cycles == Some(0) {
        return Err(AppError::Usage("--cycles must be at least 1: zero cycles is not a run (give --t-end to run for a time)".into()));
    }
    for s in &spec.sets {
        graph::apply_set(&mut flat, s)?;
    }
    let circuit = graph::build(&flat)?;
    let mut opts = solve::options_from(&circuit.simulation)?;
    opts.cancel = spec.cancel.clone();
    if let Some(n) = spec.cycles {
        opts.cycles = Some(n);
        if spec.t_end.is_none() && circuit.simulation.t_end.is_none() {
            opts.t_end = 60.0 * n.max(1) as f64;
        }
    }
    if let Some(t) = spec.t_end {
        if !(t > 0.0 && t.is_finite()) {
            return Err(AppError::Usage(format!("--t-end must be > 0 s, got {}", units::show::num(t))));
        }
        opts.t_end = t;
        // an explicit end time without --cycles runs to that time
        if spec.cycles.is_none() {
            opts.cycles = None;
        }
    }
    let outputs = circuit.simulation.outputs.clone();
    let name = circuit.name.clone();
    let warnings = circuit.warnings.clone();
    let model = solve::Model::new(circuit);
    solve::budget::check(&model, &opts, crate::load::limits().max_memory_mib).map_err(|e| AppError::Usage(e.to_string()))?;
    Ok(Prepared { name, outputs, model, opts, warnings })
}

/// Run a prepared model. A run that counts cycles and reaches its end time
/// first is still a result; `incomplete` then says where it stalled.
pub fn execute(mut p: Prepared) -> Result<Run, AppError> {
    let result = solve::simulate(&mut p.model, &p.opts)?;
    Ok(finished(p.name, result, &p.opts))
}

/// A finished run: says if it did less than `opts` asked.
pub(crate) fn finished(name: String, result: solve::SimResult, opts: &solve::SimOptions) -> Run {
    let incomplete = match opts.cycles {
        Some(n) if result.completed_cycles() < n => Some(format!(
            "only {} of {n} cycles completed by t = {:.3} s: {}",
            result.completed_cycles(),
            result.t_final,
            result.final_state.describe()
        )),
        _ => None,
    };
    Run { name, result, incomplete }
}
