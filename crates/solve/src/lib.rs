//! Flattening a wired circuit into one hybrid ODE and integrating it.
//!
//! Owns: the resource estimate of a run ([`budget`]), the flat state vector and right-hand side ([`model`]), algebraic
//! junctions ([`junction`]), the Jacobian's structure ([`jacobian`]) and its exact values by the chain rule over the blocks'
//! partial derivatives ([`exact`], with the per-block fallback [`block_differences`]), stick–slip and end-stop modes of mechanical
//! nodes ([`mechanics`]), the rest state before t = 0 ([`rest`]), the event loop and result sampling ([`simulate`]),
//! stepping a model from outside between communication points ([`stepper`]),
//! forward parameter sensitivities through events ([`sensitivity`]),
//! the reading of simulation settings ([`settings`]), and the values of the netlist's interface inputs and outputs
//! ([`interface`]).
//! Never knows: concrete block types (blocks are reached through the
//! `Block` trait only), files, terminals.

pub mod block_differences;
pub mod budget;
pub mod exact;
pub mod interface;
pub mod jacobian;
pub mod junction;
pub mod linearize;
pub mod mechanics;
pub mod model;
pub mod rest;
pub mod sensitivity;
pub mod settings;
pub mod simulate;
pub mod stepper;

pub use interface::InputError;
pub use model::{Model, ModelError};
pub use rest::{RestError, RestReport, RestValue};
pub use sensitivity::{simulate_with_sensitivities, Parameter, Sensitivities};
pub use settings::options_from;
pub use simulate::{
    simulate, simulate_observed, Balance, Cancel, Checkpoint, CheckpointKind, EventLog, FinalState, JacobianMethod, MassState, SimOptions,
    SimResult, SolveError, StrokeStatistic,
};
pub use stepper::Stepper;
