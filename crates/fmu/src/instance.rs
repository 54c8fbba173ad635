//! One FMU instance: the netlist, the values set from outside, and the
//! stepper once the circuit is built. Plain Rust; [`crate::ffi`] wraps it.

use pneumo_app::fmu::{Causality, Variable};
use pneumo_app::load::Source;
use pneumo_app::AppError;
use solve::Stepper;
use std::path::Path;

/// An instance of the FMU (see the crate documentation).
#[derive(Debug, Clone)]
pub struct Instance {
    source: Source,
    pub variables: Vec<Variable>,
    n_inputs: usize,
    /// Current values of every variable, in its unit (outputs: last read).
    values: Vec<f64>,
    /// Time of the importer's clock at which the model's t = 0 lies [s].
    start_time: f64,
    stepper: Option<Stepper>,
    /// Initialization has ended: parameters are fixed from now on.
    initialized: bool,
}

impl Instance {
    /// Load `resources/model.json` from `resources` and check the GUID.
    pub fn new(resources: &Path, guid: Option<&str>) -> Result<Instance, AppError> {
        let (flat, source) = Source::read(&resources.join("model.json"))?;
        let expected = pneumo_app::fmu::guid(&source);
        if let Some(guid) = guid.filter(|g| *g != expected) {
            return Err(AppError::Usage(format!(
                "GUID {} does not match the netlist in {} ({expected}): the modelDescription.xml and the resources come from different exports",
                graph::escape(guid),
                pneumo_app::error::shown_path(resources)
            )));
        }
        let variables = pneumo_app::fmu::variables(&flat)?;
        let n_inputs = variables.iter().filter(|v| v.causality == Causality::Input).count();
        let values = variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
        Ok(Instance { source, variables, n_inputs, values, start_time: 0.0, stepper: None, initialized: false })
    }

    /// Back to the state right after instantiation.
    pub fn reset(&mut self) {
        self.values = self.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
        self.stepper = None;
        self.initialized = false;
        self.start_time = 0.0;
    }

    pub fn set_start_time(&mut self, t: f64) {
        self.start_time = t;
    }

    fn variable(&self, vr: u32) -> Result<&Variable, AppError> {
        self.variables.get(vr as usize).ok_or_else(|| AppError::Usage(format!("no variable has value reference {vr}")))
    }

    /// Set variable `vr` to `value` (in its unit).
    pub fn set(&mut self, vr: u32, value: f64) -> Result<(), AppError> {
        let v = self.variable(vr)?.clone();
        match v.causality {
            Causality::Output => return Err(AppError::Usage(format!("\"{}\" is an output: it cannot be set", v.name))),
            Causality::Parameter if self.initialized => {
                return Err(AppError::Usage(format!("parameter \"{}\" is fixed after initialization: set it before", v.name)))
            }
            Causality::Parameter => self.stepper = None, // built again with the new value
            Causality::Input => {
                if let Some(s) = self.stepper.as_mut() {
                    s.set_input(vr as usize, v.to_si(value)).map_err(|e| AppError::Usage(e.to_string()))?;
                }
            }
        }
        self.values[vr as usize] = value;
        Ok(())
    }

    /// Value of variable `vr` (in its unit); builds the circuit if an output
    /// is asked for before the first step.
    pub fn get(&mut self, vr: u32) -> Result<f64, AppError> {
        let v = self.variable(vr)?;
        if v.causality != Causality::Output {
            return Ok(self.values[vr as usize]);
        }
        let k = vr as usize - self.n_inputs;
        let stepper = self.ensure_stepper()?;
        let mut out = vec![0.0; stepper.model().circuit.interface.outputs.len()];
        stepper.outputs(&mut out)?;
        let value = self.variables[vr as usize].in_unit(out[k]);
        self.values[vr as usize] = value;
        Ok(value)
    }

    /// End of initialization: build the circuit with the parameters and inputs set.
    pub fn exit_initialization(&mut self) -> Result<(), AppError> {
        self.ensure_stepper()?;
        self.initialized = true;
        Ok(())
    }

    fn ensure_stepper(&mut self) -> Result<&mut Stepper, AppError> {
        if self.stepper.is_none() {
            let mut flat = self.source.load()?;
            for (v, &x) in self.variables.iter().zip(&self.values) {
                if v.causality == Causality::Parameter && Some(x) != v.start {
                    graph::apply_set(&mut flat, &pneumo_app::fmu::assignment(v, x))?;
                }
            }
            let circuit = graph::build_with(&flat, graph::Drive::External)?;
            let opts = solve::options_from(&circuit.simulation)?;
            let mut model = solve::Model::new(circuit);
            for (k, v) in self.variables[..self.n_inputs].iter().enumerate() {
                model.set_input(k, v.to_si(self.values[k])).map_err(|e| AppError::Usage(e.to_string()))?;
            }
            self.stepper = Some(Stepper::new(model, &opts)?);
        }
        Ok(self.stepper.as_mut().expect("built above"))
    }

    /// Advance from the communication point `t` (importer's clock) by `h`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), AppError> {
        if !(h >= 0.0 && h.is_finite()) {
            return Err(AppError::Usage(format!("communication step must be >= 0 s, got {h}")));
        }
        let start = self.start_time;
        let stepper = self.ensure_stepper()?;
        let now = stepper.t() + start;
        if (t - now).abs() > 1e-9 * now.abs().max(1.0) {
            return Err(AppError::Usage(format!(
                "step from t = {t} s, but the model is at t = {now} s (going back needs fmi2SetFMUstate)"
            )));
        }
        stepper.advance_to(t + h - start)?;
        Ok(())
    }

    /// Current time on the importer's clock [s].
    pub fn time(&self) -> f64 {
        self.stepper.as_ref().map_or(0.0, Stepper::t) + self.start_time
    }
}
