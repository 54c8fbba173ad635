//! Stepping a model from outside: advance to a communication point with the
//! inputs held, handle the events on the way, restart after an input changes.
//!
//! This is what a co-simulation master (an FMU's `fmi2DoStep`, a controller
//! written in Python) needs, where [`crate::simulate`] runs a whole netlist
//! by itself. A [`Stepper`] starts like a run — rest state, initial modes,
//! events at t = 0 — and then integrates only when asked, to the time asked:
//! the integrator stops exactly there (it never steps past a communication
//! point, since the inputs may change at it). Between calls the inputs may
//! change ([`Stepper::set_input`]); a change is a discontinuity, so the next
//! call first handles the events it causes at the current instant (a valve
//! whose command flipped, a piston that breaks away) and restarts the
//! integrator. Unchanged inputs cost nothing: the integration simply goes on.
//!
//! A stepper is `Clone`: a copy is the complete state of the simulation
//! (model, discrete states of every block, integrator history), which an FMU
//! hands out as its `fmi2FMUstate`.

use crate::model::Model;
use crate::simulate::{self, EventLog, Jacobian, SimOptions, SimResult, SolveError, System};
use blocks::block::CycleRecord;
use ode::{Advance, Dense, Integrator, Rosenbrock};

/// A model being stepped from outside (see the module documentation).
#[derive(Debug)]
pub struct Stepper {
    model: Model,
    integrator: Rosenbrock,
    jacobian: Jacobian,
    t: f64,
    y: Vec<f64>,
    /// Events and cycles since they were last taken.
    log: SimResult,
    /// Most events within one call of [`Stepper::advance_to`].
    max_events: usize,
    /// An input changed since the last step: handle its events before integrating.
    restart: bool,
    rest: crate::rest::RestReport,
}

impl Clone for Stepper {
    fn clone(&self) -> Self {
        Stepper {
            model: self.model.clone(),
            integrator: self.integrator.clone(),
            // the Jacobian holds scratch buffers and the model's structure only
            jacobian: Jacobian::for_model(&self.model, self.jacobian.method()),
            t: self.t,
            y: self.y.clone(),
            log: self.log.clone(),
            max_events: self.max_events,
            restart: self.restart,
            rest: self.rest.clone(),
        }
    }
}

impl Stepper {
    /// Start `model` at t = 0 with the settings of `opts` (tolerances, largest
    /// step, method, the event limit; `t_end`, `cycles` and sampling are the
    /// caller's business): the rest state if the netlist asks for it, with the
    /// inputs as they are set now, then the events of t = 0.
    pub fn new(mut model: Model, opts: &SimOptions) -> Result<Stepper, SolveError> {
        let rest = if model.circuit.simulation.initial == graph::netlist::InitialMode::Rest {
            crate::rest::apply(&mut model)?
        } else {
            Default::default()
        };
        let mut y = model.initial_state();
        let integrator = simulate::integrator_for(&model, opts, &y)?;
        let jacobian = Jacobian::for_model(&model, opts.jacobian);
        model.velocity_band = opts.atol;
        let mut log = SimResult::default();
        simulate::initial_modes(&mut model, 0.0, &y)?;
        simulate::resolve_events(&mut model, 0.0, &mut y, &[], &[], &mut log)?;
        Ok(Stepper { model, integrator, jacobian, t: 0.0, y, log, max_events: opts.max_events, restart: false, rest })
    }

    /// Current time [s].
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Current state vector (block states, then quadratures).
    pub fn state(&self) -> &[f64] {
        &self.y
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Initial values the rest state chose.
    pub fn rest(&self) -> &crate::rest::RestReport {
        &self.rest
    }

    /// Set interface input `k` to `value` [SI], held from now on. A value
    /// equal to the current one changes nothing; another one takes effect
    /// at once and makes the next [`Stepper::advance_to`] restart.
    pub fn set_input(&mut self, k: usize, value: f64) -> Result<(), crate::InputError> {
        if value.to_bits() == self.model.input_value(k).to_bits() {
            return Ok(());
        }
        self.model.set_input(k, value)?;
        self.restart = true;
        Ok(())
    }

    /// The interface outputs [SI] at the current time, in the interface's
    /// order (NaN where a value is undefined at this instant).
    pub fn outputs(&mut self, out: &mut [f64]) -> Result<(), SolveError> {
        Ok(self.model.interface_outputs(self.t, &self.y, out)?)
    }

    /// Integrate to `t_target` with the inputs held, handling every event on
    /// the way; the integrator stops exactly at `t_target`. A target at or
    /// before the current time only handles a pending input change.
    pub fn advance_to(&mut self, t_target: f64) -> Result<(), SolveError> {
        if !t_target.is_finite() {
            return Err(SolveError::Settings(format!("cannot step to t = {t_target} s")));
        }
        if self.restart {
            // the inputs jumped: what that sets off happens now, then the integration starts afresh
            let due = simulate::due_time_events(&self.model, self.t);
            simulate::resolve_events(&mut self.model, self.t, &mut self.y, &[], &due, &mut self.log)?;
            self.integrator.reset();
            self.restart = false;
        }
        let mut events = 0usize;
        while self.t < t_target {
            let t_time_event =
                self.model.circuit.instances.iter().filter_map(|i| i.block.next_time_event(self.t)).fold(f64::INFINITY, f64::min);
            let t_stop = t_target.min(t_time_event);
            let advance = {
                let mut sys = System { model: &mut self.model, error: None, jacobian: &mut self.jacobian, cancel: None, sens: None };
                match self.integrator.advance(&mut sys, &mut self.t, &mut self.y, t_stop, &mut |_: &dyn Dense| {}) {
                    Ok(a) => a,
                    Err(e) => return Err(simulate::advance_error(e, sys.error.take(), sys.model, false, self.t)),
                }
            };
            let crossings = match advance {
                Advance::Reached => Vec::new(),
                Advance::Root { indices } => indices,
            };
            let due = simulate::due_time_events(&self.model, self.t);
            if !crossings.is_empty() || !due.is_empty() {
                events += 1;
                if events > self.max_events {
                    return Err(SolveError::TooManyEvents { t: self.t, limit: self.max_events });
                }
                simulate::resolve_events(&mut self.model, self.t, &mut self.y, &crossings, &due, &mut self.log)?;
                self.integrator.reset();
            }
        }
        Ok(())
    }

    /// The events since the last call (valve switches, stick–slip
    /// transitions, controller notes), oldest first.
    pub fn take_events(&mut self) -> Vec<EventLog> {
        std::mem::take(&mut self.log.events)
    }

    /// The cycles completed since the last call, oldest first.
    pub fn take_cycles(&mut self) -> Vec<CycleRecord> {
        std::mem::take(&mut self.log.cycles)
    }

    /// Work counters of the integrator so far.
    pub fn stats(&self) -> ode::Stats {
        self.integrator.stats()
    }
}
