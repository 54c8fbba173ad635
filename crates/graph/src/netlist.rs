//! The JSON netlist: components, connections, simulation settings, and the
//! interface a netlist exposes when used as a subsystem.
//!
//! These serde types are the file format; their JSON Schema is generated from
//! them (`pneumo schema`, docs/netlist.schema.json). Values of parameters are
//! kept raw here (number, text with unit, or list) and parsed against each
//! block's declarations when the circuit is built.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A circuit (or a reusable subsystem).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Netlist {
    /// Short name of the circuit.
    #[serde(default)]
    pub name: Option<String>,
    /// Free text: what the circuit is, where its numbers come from.
    #[serde(default)]
    pub description: Option<String>,
    /// Gas model for the whole circuit.
    #[serde(default)]
    pub gas: GasChoice,
    /// The components.
    pub components: Vec<Component>,
    /// Connections between ports, "id.port" to "id.port".
    #[serde(default)]
    pub connections: Vec<Connection>,
    /// Simulation settings (ignored in a subsystem).
    #[serde(default)]
    pub simulation: Simulation,
    /// Ports and parameters exposed when this netlist is used as a subsystem.
    #[serde(default)]
    pub interface: Option<Interface>,
}

/// Gas model selection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct GasChoice {
    /// "ideal" (constant cp), "semi_perfect" (cp(T)) or "real" (virial EOS).
    #[serde(default)]
    pub model: GasModelName,
    /// "air" or "nitrogen".
    #[serde(default)]
    pub species: Species,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum GasModelName {
    #[default]
    Ideal,
    SemiPerfect,
    Real,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum Species {
    #[default]
    Air,
    Nitrogen,
}

impl GasModelName {
    /// The words a netlist or `--set gas.model=` accepts.
    pub const NAMES: &'static [&'static str] = &["ideal", "semi_perfect", "real"];
}

impl Species {
    /// The words a netlist or `--set gas.species=` accepts.
    pub const NAMES: &'static [&'static str] = &["air", "nitrogen"];
}

/// A parameter value: a number in SI units, a string with a unit ("4 bar"),
/// or a list of these.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Value {
    Number(f64),
    Text(String),
    List(Vec<Value>),
}

impl Value {
    pub fn to_raw(&self) -> blocks::RawValue {
        match self {
            Value::Number(x) => blocks::RawValue::Number(*x),
            Value::Text(s) => blocks::RawValue::Text(s.clone()),
            Value::List(v) => blocks::RawValue::List(v.iter().map(Value::to_raw).collect()),
        }
    }
}

/// One component instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Component {
    /// Unique id within the netlist (letters, digits, '_' and '-').
    pub id: String,
    /// Block type ("chamber", "valve_5_2", ...) or "subsystem".
    #[serde(rename = "type")]
    pub kind: String,
    /// Netlist file of a subsystem, relative to this netlist.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Parameters: SI numbers or strings with units.
    #[serde(default)]
    pub params: BTreeMap<String, Value>,
    /// Initial conditions (same syntax as parameters).
    #[serde(default)]
    pub init: BTreeMap<String, Value>,
}

/// A connection between two ports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Connection {
    /// ["dcv.A", "head.port"]
    Pair([String; 2]),
    /// {"from": "head.p", "to": "friction.p1"}
    Object { from: String, to: String },
}

impl Connection {
    pub fn ends(&self) -> (&str, &str) {
        match self {
            Connection::Pair([a, b]) => (a, b),
            Connection::Object { from, to } => (from, to),
        }
    }
}

/// Simulation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// End time ("10 s"); the run also ends when the cycles are done.
    #[serde(default)]
    pub t_end: Option<Value>,
    /// Number of actuator cycles to run (overrides the cycler's own count).
    #[serde(default)]
    pub cycles: Option<u64>,
    /// Relative tolerance of the integrator.
    #[serde(default = "default_rtol")]
    pub rtol: f64,
    /// Absolute tolerance, relative to each state's typical size.
    #[serde(default = "default_atol")]
    pub atol: f64,
    /// Output sample interval ("1 ms"); event instants are added.
    #[serde(default)]
    pub sample_interval: Option<Value>,
    /// Largest integration step ("10 ms").
    #[serde(default)]
    pub max_step: Option<Value>,
    /// Signals to write ("head.p", "piston.x"); empty = all.
    #[serde(default)]
    pub outputs: Vec<String>,
}

fn default_rtol() -> f64 {
    1e-6
}
fn default_atol() -> f64 {
    1e-6
}

impl Default for Simulation {
    fn default() -> Self {
        Simulation {
            t_end: None,
            cycles: None,
            rtol: default_rtol(),
            atol: default_atol(),
            sample_interval: None,
            max_step: None,
            outputs: Vec::new(),
        }
    }
}

/// What a subsystem netlist exposes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct Interface {
    /// Exposed port name → inner "id.port".
    #[serde(default)]
    pub ports: BTreeMap<String, String>,
    /// Exposed parameter name → the inner "id.param" it sets (one or more).
    #[serde(default)]
    pub params: BTreeMap<String, Vec<String>>,
}

/// Split "id.port" at the last dot.
pub fn split_ref(r: &str) -> Option<(&str, &str)> {
    let (id, port) = r.rsplit_once('.')?;
    (!id.is_empty() && !port.is_empty()).then_some((id, port))
}

/// JSON Schema of the netlist format.
pub fn schema() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(Netlist)).unwrap_or(serde_json::Value::Null)
}
