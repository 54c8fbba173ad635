//! What a run will need, estimated before it starts, so that work that cannot
//! fit is refused up front with the number and the setting that raises it
//! instead of growing memory or running for ever.
//!
//! Estimates (upper bounds for the settings given):
//! - recorded samples: t_end / sample_interval (plus event instants, not
//!   counted), each a row of the model's outputs (16 bytes a value, plus the
//!   time and the row's own bookkeeping);
//! - the integrator's matrices: a dense Jacobian and its LU factors,
//!   2·n²·8 bytes for n states;
//! - steps: at least t_end / max_step.

use crate::model::Model;
use crate::simulate::SimOptions;

/// Most integration steps a run may plan (t_end / max_step).
pub const MAX_PLANNED_STEPS: f64 = 1e9;

/// Bytes one recorded sample takes.
pub fn sample_bytes(model: &Model) -> f64 {
    16.0 * model.n_outputs as f64 + 56.0
}

/// Bytes of the dense Jacobian and LU factors.
pub fn matrix_bytes(model: &Model) -> f64 {
    let n = model.dim() as f64;
    16.0 * n * n
}

use units::show::num as short;

/// Why a run was refused before it started.
#[derive(Debug, thiserror::Error)]
pub enum BudgetError {
    #[error(
        "the run would record up to {samples:.3e} samples (t_end {} s / sample_interval {} s), about {mib:.3e} MiB, more than --max-memory {limit} MiB: raise simulation.sample_interval, shorten the run, or raise --max-memory",
        short(*t_end),
        short(*interval)
    )]
    Samples { samples: f64, t_end: f64, interval: f64, mib: f64, limit: u64 },
    #[error(
        "the solver would need about {mib:.0} MiB for the dense matrices of {n} states, more than --max-memory {limit} MiB: split the circuit or raise --max-memory"
    )]
    Matrices { n: usize, mib: f64, limit: u64 },
    #[error(
        "the run would take at least {steps:.3e} steps (t_end {} s / max_step {} s), more than {MAX_PLANNED_STEPS:e}: raise simulation.max_step or shorten the run",
        short(*t_end),
        short(*max_step)
    )]
    Steps { steps: f64, t_end: f64, max_step: f64 },
}

/// Check a run against a memory limit [MiB] before it starts.
pub fn check(model: &Model, opts: &SimOptions, max_memory_mib: u64) -> Result<(), BudgetError> {
    let limit = max_memory_mib as f64 * 1024.0 * 1024.0;
    let matrices = matrix_bytes(model);
    if matrices > limit {
        return Err(BudgetError::Matrices { n: model.dim(), mib: matrices / 1048576.0, limit: max_memory_mib });
    }
    let steps = opts.t_end / opts.max_step;
    if steps.is_nan() || steps > MAX_PLANNED_STEPS {
        return Err(BudgetError::Steps { steps, t_end: opts.t_end, max_step: opts.max_step });
    }
    if opts.sample_interval > 0.0 {
        let samples = opts.t_end / opts.sample_interval;
        let bytes = samples * sample_bytes(model) + matrices;
        if bytes.is_nan() || bytes > limit {
            return Err(BudgetError::Samples {
                samples,
                t_end: opts.t_end,
                interval: opts.sample_interval,
                mib: bytes / 1048576.0,
                limit: max_memory_mib,
            });
        }
    }
    Ok(())
}
