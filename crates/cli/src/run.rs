//! Running one simulation from a netlist file with overrides: shared by
//! `simulate` (and later `sweep`).

use crate::error::CliError;
use crate::load::flat_netlist;
use std::path::Path;

/// Inputs of one run besides the netlist file.
#[derive(Debug, Clone, Default)]
pub struct RunSpec {
    pub sets: Vec<String>,
    pub cycles: Option<u64>,
    pub t_end: Option<f64>,
}

/// A finished run with the names the user asked to write.
pub struct Run {
    pub name: String,
    pub outputs: Vec<String>,
    pub result: solve::SimResult,
}

pub fn run(path: &Path, spec: &RunSpec) -> Result<Run, CliError> {
    let flat = flat_netlist(path, &spec.sets)?;
    let circuit = graph::build(&flat)?;
    let mut opts = solve::options_from(&circuit.simulation)?;
    if let Some(n) = spec.cycles {
        opts.cycles = Some(n);
        if spec.t_end.is_none() && circuit.simulation.t_end.is_none() {
            opts.t_end = 60.0 * n.max(1) as f64;
        }
    }
    if let Some(t) = spec.t_end {
        if !(t > 0.0 && t.is_finite()) {
            return Err(CliError::Usage(format!("--t-end must be > 0 s, got {t}")));
        }
        opts.t_end = t;
    }
    let outputs = circuit.simulation.outputs.clone();
    let name = circuit.name.clone();
    let mut model = solve::Model::new(circuit);
    let result = solve::simulate(&mut model, &opts)?;
    if let Some(n) = opts.cycles {
        if (result.cycles.len() as u64) < n {
            return Err(CliError::Data(format!(
                "only {} of {n} cycles completed by t = {:.3} s (the actuator stalled or the end time is too short)",
                result.cycles.len(),
                result.t_final
            )));
        }
    }
    Ok(Run { name, outputs, result })
}
