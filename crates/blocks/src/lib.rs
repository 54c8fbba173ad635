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
/// The source behind an interface input (created by `graph`, not a netlist type).
pub mod external_input;
pub mod iso6358;
pub mod lagged_sensor;
pub mod params;
pub mod registry;
pub mod spool_paths;
pub mod suggest;
pub mod support;

/// Declares the block files and the list of every block type, one line per
/// file: `module => [ITS_TYPE_ENTRIES]`.
macro_rules! library {
    ($($module:ident => [$($entry:ident),+]),* $(,)?) => {
        $(pub mod $module;)*
        /// Every block type, in catalogue order within each file.
        pub static TYPES: &[registry::BlockType] = &[$($($module::$entry),+),*];
    };
}

library! {
    pressure_source => [TYPE, ATMOSPHERE],
    mass_flow_source => [TYPE],
    chamber => [TYPE],
    tube => [TYPE],
    conductance => [TYPE],
    capillary => [TYPE],
    check_valve => [TYPE],
    speed_control_valve => [TYPE],
    directional_valve => [TYPE_5_2, TYPE_3_2, TYPE_2_2],
    valve_5_3 => [TYPE],
    pressure_regulator => [TYPE],
    relief_valve => [TYPE],
    quick_exhaust_valve => [TYPE],
    shuttle_valve => [TYPE],
    two_pressure_valve => [TYPE],
    proportional_valve => [TYPE],
    proportional_pressure_valve => [TYPE],
    piston => [TYPE],
    friction => [TYPE],
    spring => [TYPE],
    load => [TYPE],
    cushion => [TYPE],
    pressure_sensor => [TYPE],
    temperature_sensor => [TYPE],
    flow_sensor => [TYPE],
    position_sensor => [TYPE],
    velocity_sensor => [TYPE],
    limit_switch => [TYPE],
    schedule => [TYPE],
    cycler => [TYPE],
    delay => [TYPE],
    sequencer => [TYPE],
    timer => [TYPE],
    logic_gate => [TYPE],
    pid => [TYPE],
}

pub use block::Block;
pub use params::{ParamError, ParamSpec, Params, RawValue};

/// Why a block could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BlockError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("{0}")]
    Flow(#[from] iso6358::FlowError),
    #[error("unknown component type \"{name}\"{hint} (known: {known})")]
    UnknownType { name: String, hint: String, known: String },
}

impl BlockError {
    /// A parameter that parsed but makes no sense with the others.
    pub fn invalid(name: &str, reason: &str) -> Self {
        BlockError::Param(ParamError::Invalid { name: name.into(), reason: reason.into() })
    }
}
