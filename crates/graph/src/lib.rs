//! Wiring and causality of pneumatic circuits.
//!
//! Owns: the JSON netlist format ([`netlist`]), subsystem expansion and
//! overrides ([`expand`]), the wired circuit with causality assigned
//! ([`circuit`]), the model interface — inputs and outputs — bound to it
//! ([`interface`]), and human-readable reports of it ([`report`]).
//! Never knows: the equations inside blocks, the integrator, files (reached
//! through [`expand::Loader`]), terminals.

pub mod circuit;
pub mod consistency;
pub mod expand;
pub mod interface;
pub mod library;
pub mod netlist;
pub mod params;
pub mod report;

pub use circuit::{build, build_with, Circuit, NodeCausality, PortRef};
pub use expand::{apply_set, load, FlatNetlist, Loader};
pub use interface::{Drive, ModelInterface};
pub use netlist::Netlist;
pub use params::{resolve, Resolved};

/// Input that was accepted but is probably not what the user meant; shown
/// as one line, never fatal.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Warning {
    /// File the questionable value was written in ("" for the command line or unknown).
    pub file: String,
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.file.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.file, self.message)
        }
    }
}

/// Text from the user made safe to echo in a one-line message: hidden
/// characters (newlines, escapes, ...) shown as `\u{..}`, long text
/// shortened with its length (the one rule of [`units::show::text`]).
pub fn escape(text: &str) -> String {
    units::show::text(text)
}

use blocks::block::Domain;

/// "FILE: " before a message about a component, or "" when the file is unknown.
fn file_prefix(file: &str) -> String {
    if file.is_empty() {
        String::new()
    } else {
        format!("{file}: ")
    }
}

/// Longest component id or parameter name a netlist may use [characters]:
/// every message names them, and one line must stay short.
pub const MAX_NAME_CHARS: usize = 100;

/// A netlist that cannot be turned into a circuit. Every variant names the
/// file position, component, parameter or port at fault.
#[derive(Debug, thiserror::Error)]
pub enum GraphError {
    /// An error about the wiring of a netlist, with the netlist's file.
    #[error("{file}: {source}")]
    InFile { file: String, source: Box<GraphError> },
    #[error("{file}:{line}:{column}: {message}")]
    Json { file: String, line: usize, column: usize, message: String },
    #[error("cannot read {file}: {message}")]
    Io { file: String, message: String },
    #[error("{}component \"{id}\": {source}", file_prefix(file))]
    Block { file: String, id: String, source: Box<blocks::BlockError> },
    #[error("{}component \"{id}\": {message}", file_prefix(file))]
    Component { file: String, id: String, message: String },
    #[error(
        "{}component \"{id}\": cannot read its subsystem file {path} (\"{written}\", relative to the netlist that names it): {message}",
        file_prefix(file)
    )]
    SubsystemFile { file: String, id: String, path: String, written: String, message: String },
    #[error("subsystem \"{id}\": {message}")]
    Subsystem { id: String, message: String },
    #[error("--set {assignment}: {message}")]
    Set { assignment: String, message: String },
    #[error("{file}: component id \"{}\" may contain only letters, digits, '_' and '-' (at most {MAX_NAME_CHARS})", escape(id))]
    BadId { file: String, id: String },
    #[error(
        "{file}: parameter name \"{}\" must be a letter or '_' followed by letters, digits or '_' (at most {MAX_NAME_CHARS}, and not \"pi\")",
        escape(name)
    )]
    BadParameterName { file: String, name: String },
    #[error("{file}: {subject}: {message}")]
    Parameter { file: String, subject: String, message: String },
    #[error("{file}: parameters refer to each other in a cycle: {cycle}")]
    ParameterCycle { file: String, cycle: String },
    #[error("{file}: interface {what} \"{name}\": {message}")]
    Interface { file: String, what: &'static str, name: String, message: String },
    #[error("{}component id \"{id}\" is used twice", file_prefix(file))]
    DuplicateId { file: String, id: String },
    #[error("\"{reference}\" is not of the form ID.PORT")]
    BadRef { reference: String },
    #[error("\"{reference}\": no component \"{id}\"")]
    UnknownComponent { reference: String, id: String },
    #[error("\"{reference}\": no such port (ports: {ports})")]
    UnknownPort { reference: String, ports: String },
    #[error("\"{reference}\" is connected to itself")]
    SelfConnection { reference: String },
    #[error("cannot connect \"{a}\" ({da}) to \"{b}\" ({db}): ports of different domains")]
    DomainMismatch { a: String, da: Domain, b: String, db: Domain },
    #[error("signal connection \"{a}\" - \"{b}\" must join one output to one input")]
    SignalDirection { a: String, b: String },
    #[error("signal input \"{reference}\" is driven by more than one output")]
    SignalDriven { reference: String },
    #[error("port \"{reference}\" is not connected ({doc})")]
    Unconnected { reference: String, doc: String },
    #[error(
        "{ports} both impose pressure on one node (derivative causality): join them through a conductance, or merge them into one chamber"
    )]
    DerivativeCausality { ports: String },
    #[error("node of {ports} has neither a capacity nor a source: its pressure is undefined")]
    FloatingNode { ports: String },
    #[error("mechanical node of {ports} has no moving mass (add a piston)")]
    NoInertia { ports: String },
    #[error("{ports} are masses tied rigidly together: merge them into one piston")]
    TiedInertias { ports: String },
    #[error("signal loop through \"{id}\" with no state to break it")]
    SignalLoop { id: String },
    #[error("{}component \"{id}\", parameter \"{param}\": {message}", file_prefix(file))]
    Inconsistent { file: String, id: String, param: String, message: String },
}

impl GraphError {
    /// The error with the netlist's file in front, when it names none
    /// itself (a connection, a port, a node); command-line errors (`--set`)
    /// stay as they are.
    pub fn in_file(self, file: &str) -> GraphError {
        use GraphError::*;
        match self {
            e @ (InFile { .. } | Json { .. } | Io { .. } | Set { .. } | BadId { .. } | BadParameterName { .. } | Parameter { .. }) => e,
            e @ (ParameterCycle { .. } | Interface { .. } | Block { .. } | Component { .. } | SubsystemFile { .. }) => e,
            e @ (DuplicateId { .. } | Inconsistent { .. }) => e,
            e if file.is_empty() => e,
            e => InFile { file: file.to_string(), source: Box::new(e) },
        }
    }
}
