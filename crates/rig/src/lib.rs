//! HEADER PLACEHOLDER

pub mod error;
pub mod flow;
pub mod friction;
pub mod gas;
mod linalg;
pub mod model;
pub mod params;
mod roots;
pub mod sdirk;
pub mod sensors;
pub mod sim;
pub mod tank;

pub use error::RigError;
pub use flow::{CheckLaw, LeakLaw, Restriction, SubsonicLaw, LPM_PER_BAR};
pub use friction::{Eq37, FrictionVariant, Stribeck, StribeckShape};
pub use gas::{Gas, GasLaw};
pub use model::ValvePos;
pub use params::{Effects, InitialState, ModelForm, Rig, RunSpec, Sampling, SupplyLine, Switches};
pub use sdirk::SolverStats;
pub use sim::{simulate, Balance, CycleTimes, EventKind, EventRecord, Trace};
