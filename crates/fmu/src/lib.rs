//! The runtime library of pneumo's FMUs: FMI 2.0 Co-Simulation.
//!
//! `pneumo fmu` (the use case `pneumo_app::fmu`) packs this library as
//! `binaries/linux64/<modelIdentifier>.so` next to the netlist in
//! `resources/`. `fmi2Instantiate` reads the netlist from the resource
//! location the importer passes, lists the variables the way the exporter
//! did ([`pneumo_app::fmu::variables`]), and checks the GUID. Parameters set
//! before initialization are applied as `--set` overrides when the circuit
//! is built (at the end of initialization, or when an output is read during
//! it); `fmi2DoStep` advances a [`solve::Stepper`] to the next communication
//! point, holding the inputs.
//!
//! Every exported function runs inside `catch_unwind`: no panic crosses into
//! the importer's process. Errors go to the importer's logger as the
//! command line's one-line messages, and the function returns `fmi2Error`.
//! The FMI 2.0 types are declared here ([`ffi`]): the crates that offer them
//! (`fmi`, `fmi-export`) are for importing FMUs or exporting FMI 3.0 models
//! with a fixed set of variables, and ours come from the netlist.
//! Model Exchange, FMI 3.0 and serialized FMU states are not offered.

pub mod ffi;
mod instance;

pub use instance::Instance;
