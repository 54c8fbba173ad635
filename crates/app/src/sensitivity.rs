//! One run with forward parameter sensitivities for named netlist
//! parameters ("friction.k0"): builds, per parameter, the model at
//! `θ + δ` (δ = 1e-7·|θ|) that `solve::sensitivity` differences against,
//! and returns the run with ∂(channel)/∂θ of every recorded channel on its
//! grid, in the channel's SI unit per SI unit of the parameter.

use crate::error::AppError;
use crate::run::{finished, prepare, Run, RunSpec};
use graph::FlatNetlist;
use identify::netlist_edit::{param_si, set_param_si, split_target};

/// Relative size of the parameter perturbation (see `solve::sensitivity`
/// for the error it gives).
pub const RELATIVE_DELTA: f64 = 1e-7;

/// Run `flat` (with `spec`'s overrides) and integrate the sensitivities to
/// `params` ("ID.PARAM" of components, numeric quantities, non-zero).
pub fn run_with_sensitivities(mut flat: FlatNetlist, spec: &RunSpec, params: &[String]) -> Result<(Run, solve::Sensitivities), AppError> {
    for s in &spec.sets {
        graph::apply_set(&mut flat, s)?;
    }
    let bare = RunSpec { sets: Vec::new(), ..spec.clone() };
    let mut perturbed = Vec::with_capacity(params.len());
    for name in params {
        let usage = |e: identify::netlist_edit::EditError| AppError::Usage(format!("sensitivity to {}: {e}", graph::escape(name)));
        let (id, param) = split_target(name).map_err(usage)?;
        let value = param_si(&flat, id, param).map_err(usage)?;
        if !(value.is_finite() && value != 0.0) {
            return Err(AppError::Usage(format!(
                "sensitivity to {}: the parameter is {}; a relative perturbation needs a finite non-zero value",
                graph::escape(name),
                units::show::num(value)
            )));
        }
        let delta = RELATIVE_DELTA * value.abs();
        let mut copy = flat.clone();
        set_param_si(&mut copy, id, param, value + delta).map_err(usage)?;
        let model = prepare(copy, &bare)?.model;
        perturbed.push(solve::Parameter { name: name.clone(), model, delta });
    }
    let mut p = prepare(flat, &bare)?;
    let (result, sens) = solve::simulate_with_sensitivities(&mut p.model, perturbed, &p.opts)?;
    Ok((finished(p.name, result, &p.opts), sens))
}
