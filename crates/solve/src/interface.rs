//! The netlist's interface at run time: setting inputs, reading outputs.
//!
//! `graph` binds the interface ([`graph::interface`]): each input to a live
//! parameter of one block (the source block of a port input, or the block
//! parameter it names), each output to a recorded value. Here the model
//! takes input values between integration steps — the caller restarts the
//! integration after a change, since a step holds them constant — and
//! reports output values at a state. All values are SI; the outer units are
//! the front end's business ([`graph::interface::OuterUnit`]).

use crate::model::Model;
use graph::interface::OutputSource;

/// An input value the model cannot take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("input \"{name}\" = {value}: {message}")]
pub struct InputError {
    pub name: String,
    /// The value as given, in the input's outer unit ("-1 bar").
    pub value: String,
    pub message: String,
}

impl Model {
    /// Number of interface inputs.
    pub fn n_inputs(&self) -> usize {
        self.input_values.len()
    }

    /// Current value of interface input `k` [SI].
    pub fn input_value(&self, k: usize) -> f64 {
        self.input_values[k]
    }

    /// Set interface input `k` to `value` [SI]. Call it between integration
    /// steps only and restart the integration afterwards: the value is held
    /// constant over a step. A value outside the range of the parameter it
    /// drives (a supply pressure ≤ 0) or not finite is refused, and the input
    /// keeps its previous value.
    pub fn set_input(&mut self, k: usize, value: f64) -> Result<(), InputError> {
        let input = &self.circuit.interface.inputs[k];
        let refuse = |message: String| {
            let shown = input.unit.from_si(value);
            let unit = if input.unit.text.is_empty() || input.unit.text == "1" { String::new() } else { format!(" {}", input.unit.text) };
            InputError { name: input.name.clone(), value: format!("{}{unit}", units::show::num(shown)), message }
        };
        if !value.is_finite() {
            return Err(refuse("must be finite".into()));
        }
        if let Some(live) = &input.live {
            if let Some(spec) = &live.spec {
                spec.check(value).map_err(|e| match e {
                    blocks::ParamError::OutOfRange { reason, .. } => refuse(reason),
                    other => refuse(other.to_string()),
                })?;
            }
            let (block, param) = (live.block, live.param);
            self.circuit.instances[block].block.set_live_parameter(param, value);
        }
        self.input_values[k] = value;
        Ok(())
    }

    /// Values [SI] of the interface outputs at (t, y), in the interface's
    /// order. Like [`Model::record`], it leaves no trace in the run. A value
    /// undefined at this instant (a polytropic index while nothing flows) is NaN.
    pub fn interface_outputs(&mut self, t: f64, y: &[f64], out: &mut [f64]) -> Result<(), crate::ModelError> {
        let mut row = vec![None; self.n_outputs];
        self.record(t, y, &mut row)?;
        for (value, output) in out.iter_mut().zip(&self.circuit.interface.outputs) {
            *value = match output.source {
                OutputSource::Signal { block, index } => row[self.slots[block].outputs.start + index],
                OutputSource::Recorded { block, index } => row[self.slots[block].outputs.start + self.slots[block].sig_out.len() + index],
                OutputSource::Quadrature { block, index } => Some(y[self.slots[block].quad.start + index]),
            }
            .unwrap_or(f64::NAN);
        }
        Ok(())
    }
}
