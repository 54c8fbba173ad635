//! Turning the netlist's simulation settings (with units) into [`SimOptions`].

use crate::simulate::{Cancel, SimOptions, SolveError};
use graph::netlist::{Simulation, Value};
use std::cell::RefCell;
use units::dim;

thread_local! {
    static THREAD_CANCEL: RefCell<Option<Cancel>> = const { RefCell::new(None) };
}

/// Give every [`SimOptions`] that [`options_from`] makes on this thread the
/// cancellation flag `cancel` (or none). For runs started by code that builds
/// its own options, such as the `identify` workflow, on threads the caller
/// owns (the Python package sets it on the threads of a pool it creates for
/// one analysis, so that Ctrl-C stops every simulation of that analysis).
pub fn set_thread_cancel(cancel: Option<Cancel>) {
    THREAD_CANCEL.with(|c| *c.borrow_mut() = cancel);
}

fn seconds(v: &Option<Value>, name: &str, default: f64) -> Result<f64, SolveError> {
    match v {
        None => Ok(default),
        Some(Value::Number(x)) => Ok(*x),
        Some(Value::Text(s)) => units::parse_quantity(s, dim::TIME)
            .map_err(|e| SolveError::Settings(format!("simulation.{name} = \"{}\": {e}", units::show::text(s)))),
        Some(Value::List(_)) => Err(SolveError::Settings(format!("simulation.{name} must be a single value"))),
    }
}

/// Options for a run. Without an end time, runs that count cycles get a
/// generous limit of 60 s per cycle.
pub fn options_from(sim: &Simulation) -> Result<SimOptions, SolveError> {
    let cycles = sim.cycles;
    if cycles == Some(0) {
        return Err(SolveError::Settings("simulation.cycles must be at least 1 (leave it out to run to t_end)".into()));
    }
    let default_end = match cycles {
        Some(n) => 60.0 * n.max(1) as f64,
        None => 10.0,
    };
    let t_end = seconds(&sim.t_end, "t_end", default_end)?;
    let sample_interval = seconds(&sim.sample_interval, "sample_interval", 1e-3)?;
    let max_step = seconds(&sim.max_step, "max_step", 0.05)?;
    if t_end.is_nan() || t_end <= 0.0 {
        return Err(SolveError::Settings(format!("simulation.t_end must be > 0 s, got {}", units::show::num(t_end))));
    }
    if sample_interval < 0.0 || max_step <= 0.0 {
        return Err(SolveError::Settings("simulation.sample_interval must be >= 0 and max_step > 0".into()));
    }
    if !(sim.rtol > 0.0 && sim.rtol < 0.1 && sim.atol > 0.0 && sim.atol < 1.0) {
        return Err(SolveError::Settings(format!(
            "tolerances out of range: rtol {} (0..0.1), atol {} (0..1)",
            units::show::num(sim.rtol),
            units::show::num(sim.atol)
        )));
    }
    let method = match sim.method {
        graph::netlist::MethodName::Rodas4 => ode::Method::Rodas4,
        graph::netlist::MethodName::Ros34pw2 => ode::Method::Ros34pw2,
    };
    Ok(SimOptions {
        t_end,
        cycles,
        rtol: sim.rtol,
        atol: sim.atol,
        sample_interval,
        max_step,
        max_events: 100_000,
        method,
        cancel: THREAD_CANCEL.with(|c| c.borrow().clone()),
        ..SimOptions::default()
    })
}
