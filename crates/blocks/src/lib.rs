//! Physical components of pneumatic circuits.
//!
//! Each block lives in its own file whose `//!` header lists its ports,
//! parameters (units, defaults), equations with the paper's numbers, and
//! assumptions. Blocks know physics only: no files, no solver, no wiring.
//! They are reached through the [`Block`](block::Block) trait and created by
//! name from the [`registry`].
//!
//! Paper: "Improving gas dynamic models for pneumatic systems"
//! (shared/paper in the repository); "Eq. n" below refers to it.

pub mod block;
pub mod chamber;
pub mod check_valve;
pub mod conductance;
pub mod cycler;
pub mod delay;
pub mod directional_valve;
pub mod friction;
pub mod iso6358;
pub mod mass_flow_source;
pub mod params;
pub mod piston;
pub mod pressure_source;
pub mod registry;
pub mod schedule;
pub mod speed_control_valve;
pub mod spring;

pub use block::Block;
pub use params::{ParamError, ParamSpec, Params, RawValue};

/// Why a block could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BlockError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("{0}")]
    Flow(#[from] iso6358::FlowError),
    #[error("unknown component type \"{name}\" (known: {known})")]
    UnknownType { name: String, known: String },
}

impl BlockError {
    /// A parameter that parsed but makes no sense with the others.
    pub fn invalid(name: &str, reason: &str) -> Self {
        BlockError::Param(ParamError::Invalid { name: name.into(), reason: reason.into() })
    }
}
