//! Operating points other than trims: the rest state, and a time of a
//! simulation.
//!
//! A time point is taken from the netlist running by itself (its
//! controllers closing their loops) and carried into the same netlist built
//! to be driven from outside, as a snapshot linearisation does in Simulink
//! Control Design: the states, every block's discrete state (valve
//! positions, controller steps — the blocks themselves are moved over) and
//! the mechanical modes come along, and each input bound to ports takes the
//! value those ports read at that instant (the PID's command, say), so the
//! open-loop model starts where the closed loop was.

use super::{LinearizeError, OperatingPoint, PointKind};
use crate::model::Model;
use crate::simulate::{simulate_observed, SimOptions};
use graph::interface::Binding;

/// The rest state of `model` (as `"initial": "rest"` computes it), at t = 0.
pub fn rest(model: &mut Model) -> Result<OperatingPoint, LinearizeError> {
    crate::rest::apply(model)?;
    let y = model.initial_state();
    Ok(OperatingPoint { t: 0.0, y, kind: PointKind::Rest, trim: None })
}

/// Run `standalone` to time `t` with the settings `opts` (its end time and
/// cycle count are replaced) and carry the state into `driven`, built from
/// the same netlist with [`graph::Drive::External`].
pub fn at_time(mut standalone: Model, driven: &mut Model, opts: &SimOptions, t: f64) -> Result<OperatingPoint, LinearizeError> {
    if !(t > 0.0 && t.is_finite()) {
        return Err(LinearizeError::Point(format!(
            "t = {} s: the time must be > 0 s (for the state before anything moves, use rest)",
            units::show::num(t)
        )));
    }
    let mut run = opts.clone();
    run.t_end = t;
    run.cycles = None;
    run.sample_interval = 0.0;
    run.record_steps = false;
    let mut last: Option<(f64, Vec<f64>)> = None;
    let result = simulate_observed(&mut standalone, &run, &mut |c| last = Some((c.t, c.y.to_vec())))?;
    let Some((t_last, y)) = last.filter(|(tl, _)| *tl == result.t_final) else {
        return Err(LinearizeError::Point("the run gave no state at its end".into()));
    };
    if t_last < t {
        return Err(LinearizeError::Point(format!(
            "the run ended at t = {} s, before t = {} s (a controller finished)",
            units::show::num(t_last),
            units::show::num(t)
        )));
    }
    carry(&mut standalone, driven, t_last, &y)?;
    Ok(OperatingPoint { t: t_last, y, kind: PointKind::Time, trim: None })
}

/// Move blocks, modes and input values from `from` (at (t, y)) into `into`.
fn carry(from: &mut Model, into: &mut Model, t: f64, y: &[f64]) -> Result<(), LinearizeError> {
    if from.n_states != into.n_states || from.dim() != into.dim() {
        return Err(LinearizeError::Point(format!(
            "the model driven from outside has {} states, the one that ran {}",
            into.n_states, from.n_states
        )));
    }
    // the value each port-bound input's ports read in the run
    from.eval_detached(t, y, None, None)?;
    let mut values = Vec::new();
    for (k, input) in into.circuit.interface.inputs.iter().enumerate() {
        if let Binding::Ports(ports) = &input.binding {
            if let Some(v) = ports.first().and_then(|p| port_value(from, p)) {
                values.push((k, v));
            }
        }
    }
    let n = from.circuit.instances.len().min(into.circuit.instances.len());
    for i in 0..n {
        let (a, b) = (&from.circuit.instances[i], &into.circuit.instances[i]);
        if a.id == b.id && a.block.type_name() == b.block.type_name() {
            std::mem::swap(&mut from.circuit.instances[i].block, &mut into.circuit.instances[i].block);
        }
    }
    into.modes.clone_from(&from.modes);
    into.velocity_band = from.velocity_band;
    for (k, v) in values {
        into.set_input(k, v)?;
    }
    Ok(())
}

/// The value the signal input port "id.port" reads in the last evaluation of `model`.
fn port_value(model: &Model, reference: &str) -> Option<f64> {
    let (id, port) = reference.rsplit_once('.')?;
    let b = model.circuit.instances.iter().position(|i| i.id == id)?;
    let ports = model.circuit.instances[b].block.ports();
    let p = ports.iter().position(|s| s.name == port)?;
    let k = ports[..p].iter().filter(|s| s.kind == blocks::block::PortKind::SignalIn).count();
    model.slots[b].sig.get(k).copied()
}
