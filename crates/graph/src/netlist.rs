//! The JSON netlist: components, connections, simulation settings, and the
//! interface a netlist exposes — ports and parameters when used as a
//! subsystem, inputs and outputs when driven from outside.
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
    /// Named parameters: `"bore": "45 mm"` or `"bore": {"value": "45 mm",
    /// "description": "piston diameter"}`. Component values refer to them
    /// by name in expressions (`"= pi/4 * bore^2"`). In a subsystem they are
    /// the parameters its instances may set.
    #[serde(default)]
    pub parameters: BTreeMap<String, ParameterDecl>,
    /// The components.
    pub components: Vec<Component>,
    /// Connections between ports, "id.port" to "id.port".
    #[serde(default)]
    pub connections: Vec<Connection>,
    /// Simulation settings (ignored in a subsystem).
    #[serde(default)]
    pub simulation: Simulation,
    /// Ports and parameters exposed when this netlist is used as a
    /// subsystem; inputs and outputs when it is driven from outside.
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

/// A named parameter: a value (number, text with unit, or expression), with
/// an optional description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum ParameterDecl {
    /// `{"value": "45 mm", "description": "piston diameter"}`
    Full {
        value: Value,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        description: Option<String>,
    },
    /// `"45 mm"`, `0.3`, `"= 2 * V_port"`
    Short(Value),
}

impl ParameterDecl {
    pub fn value(&self) -> &Value {
        match self {
            ParameterDecl::Full { value, .. } | ParameterDecl::Short(value) => value,
        }
    }
    pub fn description(&self) -> Option<&str> {
        match self {
            ParameterDecl::Full { description, .. } => description.as_deref(),
            ParameterDecl::Short(_) => None,
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
    /// File the component was read from (set when loading; not part of the format).
    #[serde(skip)]
    #[schemars(skip)]
    pub origin: String,
    /// Scope in which an expression value of a parameter is evaluated, when it
    /// is not the component's own (a value given by a subsystem's instance or
    /// on the command line). Set when expanding; not part of the format.
    #[serde(skip)]
    #[schemars(skip)]
    pub scopes: BTreeMap<String, String>,
}

impl Component {
    /// Scope of the names in the expression value of `param`: the subsystem
    /// instance the component belongs to ("" at the top level), unless the
    /// value came from elsewhere.
    pub fn scope_of(&self, param: &str) -> &str {
        match self.scopes.get(param) {
            Some(s) => s,
            None => self.id.rsplit_once('.').map(|(scope, _)| scope).unwrap_or(""),
        }
    }
    /// The written value of `param` (in `params` or `init`).
    pub fn value(&self, param: &str) -> Option<&Value> {
        self.params.get(param).or_else(|| self.init.get(param))
    }
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
    /// Initial state: "given" (each component's init values or their
    /// defaults) or "rest" (the state the circuit rests in before t = 0 with
    /// its controllers released; init values written explicitly still win).
    #[serde(default)]
    pub initial: InitialMode,
    /// Integration method: "ros34pw2" (Rosenbrock-W, order 3, reuses its
    /// Jacobian) or "rodas4" (Rosenbrock, order 4, a Jacobian every step).
    #[serde(default)]
    pub method: MethodName,
}

/// The integration methods a netlist may choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum MethodName {
    /// RODAS4: Rosenbrock order 4(3), L-stable, a Jacobian every step.
    #[default]
    Rodas4,
    /// ROS34PW2: Rosenbrock-W order 3(2), L-stable, reuses its Jacobian.
    Ros34pw2,
}

impl MethodName {
    pub const NAMES: &'static [&'static str] = &["rodas4", "ros34pw2"];
}

/// How the initial state is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum InitialMode {
    /// Init values as written, block defaults for the rest.
    #[default]
    Given,
    /// Chambers open to a source take its pressure and temperature, pistons
    /// rest where the forces put them; explicit init values still win.
    Rest,
}

impl InitialMode {
    pub const NAMES: &'static [&'static str] = &["given", "rest"];
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
            initial: InitialMode::Given,
            method: MethodName::default(),
        }
    }
}

/// What a netlist exposes: as a subsystem, the ports and parameters an
/// instance connects and sets; as a model driven from outside (an FMU, a
/// linearisation), its inputs and outputs. Inputs and outputs are read from
/// the top-level netlist only; an included subsystem's are ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct Interface {
    /// Exposed port name → inner "id.port".
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub ports: BTreeMap<String, String>,
    /// Exposed parameter name → the inner "id.param" it sets (one or more).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub params: BTreeMap<String, Vec<String>>,
    /// Model inputs by name: values set from outside, held between
    /// communication steps. Each drives signal input ports (a valve command,
    /// a set point) or a live block parameter (a supply pressure, an
    /// external force).
    #[serde(default, skip_serializing_if = "OrderedMap::is_empty")]
    pub inputs: OrderedMap<InputDecl>,
    /// Model outputs by name: recorded values reported to the outside
    /// (`"x": "piston.x"` or `{"from": "piston.x", "unit": "mm", "description": "..."}`).
    #[serde(default, skip_serializing_if = "OrderedMap::is_empty")]
    pub outputs: OrderedMap<OutputDecl>,
}

/// Named entries in the order the file writes them (the interface's inputs
/// and outputs: the order of a linear model's columns and rows and of an
/// FMU's variables). A JSON object; a name given twice is refused (a plain
/// map would keep the last one silently).
#[derive(Debug, Clone, PartialEq)]
pub struct OrderedMap<T>(pub Vec<(String, T)>);

impl<T> Default for OrderedMap<T> {
    fn default() -> Self {
        OrderedMap(Vec::new())
    }
}

impl<T> OrderedMap<T> {
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    pub fn len(&self) -> usize {
        self.0.len()
    }
    pub fn get(&self, name: &str) -> Option<&T> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
    pub fn contains_key(&self, name: &str) -> bool {
        self.get(name).is_some()
    }
    /// The names, in order.
    pub fn keys(&self) -> impl Iterator<Item = &String> {
        self.0.iter().map(|(n, _)| n)
    }
    pub fn iter(&self) -> impl Iterator<Item = (&String, &T)> {
        self.0.iter().map(|(n, v)| (n, v))
    }
}

impl<'a, T> IntoIterator for &'a OrderedMap<T> {
    type Item = (&'a String, &'a T);
    type IntoIter = std::iter::Map<std::slice::Iter<'a, (String, T)>, fn(&'a (String, T)) -> (&'a String, &'a T)>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter().map(|(n, v)| (n, v))
    }
}

impl<T: Serialize> Serialize for OrderedMap<T> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (name, value) in &self.0 {
            map.serialize_entry(name, value)?;
        }
        map.end()
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for OrderedMap<T> {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visit<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for Visit<T> {
            type Value = OrderedMap<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object of named entries")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<OrderedMap<T>, A::Error> {
                let mut entries: Vec<(String, T)> = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    if entries.iter().any(|(n, _)| *n == name) {
                        return Err(serde::de::Error::custom(format!("\"{}\" is given twice", crate::escape(&name))));
                    }
                    let value = map.next_value()?;
                    entries.push((name, value));
                }
                Ok(OrderedMap(entries))
            }
        }
        deserializer.deserialize_map(Visit(std::marker::PhantomData))
    }
}

/// The schema of a map of names to `T` (the order is the file's, which a schema does not state).
impl<T: JsonSchema> JsonSchema for OrderedMap<T> {
    fn inline_schema() -> bool {
        <BTreeMap<String, T>>::inline_schema()
    }
    fn schema_name() -> std::borrow::Cow<'static, str> {
        <BTreeMap<String, T>>::schema_name()
    }
    fn schema_id() -> std::borrow::Cow<'static, str> {
        <BTreeMap<String, T>>::schema_id()
    }
    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        <BTreeMap<String, T>>::json_schema(generator)
    }
}

/// One model input: what it drives (`port` or `parameter`, exactly one),
/// its unit outside, its start value and a description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InputDecl {
    /// Signal input port(s) the input drives: "dcv.command", or a list. When
    /// the model is driven from outside, the ports read the input instead of
    /// what the netlist connects to them; when the netlist runs by itself
    /// (`pneumo simulate`) a connected port keeps its connection and an
    /// unconnected one reads the start value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub port: Option<PortList>,
    /// A live block parameter the input sets: "supply.p",
    /// "cyl.piston.external_force" (docs/netlist.md lists them). Its start
    /// value is the parameter's own value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameter: Option<String>,
    /// Unit of the value outside ("bar", "mm", "1"); SI inside. Default: the
    /// SI unit of what it drives.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Value until one is set from outside (`port` inputs only; default 0):
    /// a number (SI), a text with unit ("2 bar") or an expression of the
    /// netlist's values ("= p_supply - 1 bar").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Value>,
    /// What the input means, for the people who connect it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// One port ("dcv.command") or several (["valve_a.command", "valve_b.command"]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum PortList {
    One(String),
    Many(Vec<String>),
}

impl PortList {
    pub fn ports(&self) -> Vec<&str> {
        match self {
            PortList::One(p) => vec![p.as_str()],
            PortList::Many(v) => v.iter().map(String::as_str).collect(),
        }
    }
}

/// One model output: a recorded value ("id.signal", e.g. "piston.x",
/// "head.T", "valve.mdot_a") or a running total ("supply.delivered").
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum OutputDecl {
    /// `{"from": "piston.x", "unit": "mm", "description": "piston position"}`
    Full(OutputFull),
    /// `"piston.x"` (SI unit, no description)
    Short(String),
}

/// The long form of an output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutputFull {
    /// The recorded value: "id.signal" or a running total "id.name".
    pub from: String,
    /// Unit of the value outside ("mm", "bar", "degC"); default its SI unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// What the output means.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// A text or an object, with the object's own messages (unknown or missing
/// keys, at their line and column) rather than "no variant matched".
impl<'de> Deserialize<'de> for OutputDecl {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = OutputDecl;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"id.signal\" or {\"from\": \"id.signal\", \"unit\": ..., \"description\": ...}")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<OutputDecl, E> {
                Ok(OutputDecl::Short(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<OutputDecl, A::Error> {
                OutputFull::deserialize(serde::de::value::MapAccessDeserializer::new(map)).map(OutputDecl::Full)
            }
        }
        deserializer.deserialize_any(Visit)
    }
}

impl OutputDecl {
    pub fn from(&self) -> &str {
        match self {
            OutputDecl::Full(full) => &full.from,
            OutputDecl::Short(from) => from,
        }
    }
    pub fn unit(&self) -> Option<&str> {
        match self {
            OutputDecl::Full(full) => full.unit.as_deref(),
            OutputDecl::Short(_) => None,
        }
    }
    pub fn description(&self) -> Option<&str> {
        match self {
            OutputDecl::Full(full) => full.description.as_deref(),
            OutputDecl::Short(_) => None,
        }
    }
}

/// Split "id.port" at the last dot.
pub fn split_ref(r: &str) -> Option<(&str, &str)> {
    let (id, port) = r.rsplit_once('.')?;
    (!id.is_empty() && !port.is_empty()).then_some((id, port))
}

/// JSON Schema of the netlist format, with the parameters of every block
/// type (so that an editor completes and checks `params` and `init`).
pub fn schema() -> serde_json::Value {
    use serde_json::json;
    let mut schema = serde_json::to_value(schemars::schema_for!(Netlist)).unwrap_or(serde_json::Value::Null);
    let mut types: Vec<&str> = blocks::registry::TYPES.iter().map(|t| t.name).collect();
    types.extend(crate::library::names());
    types.push("subsystem");
    let one_type = |name: &str, doc: &str, props: serde_json::Map<String, serde_json::Value>| {
        let values = json!({ "type": "object", "properties": props, "additionalProperties": false });
        json!({
            "if": { "properties": { "type": { "const": name } }, "required": ["type"] },
            "then": { "description": doc, "properties": { "params": values.clone(), "init": values } }
        })
    };
    let mut per_type: Vec<serde_json::Value> = blocks::registry::TYPES
        .iter()
        .map(|t| one_type(t.name, t.doc, t.params.iter().map(|p| (p.name.to_string(), param_schema(p))).collect()))
        .collect();
    // built-in components (`"type": "cylinder"`): an instance sets the
    // sub-circuit's declared parameters and its interface parameters, nothing else
    for entry in crate::library::ENTRIES {
        let Ok(n) = crate::library::netlist(entry) else { continue };
        let mut props: serde_json::Map<String, serde_json::Value> = n
            .parameters
            .iter()
            .map(|(name, decl)| (name.clone(), built_in_param_schema(decl.description().unwrap_or(""), &default_text(decl.value()))))
            .collect();
        for (name, targets) in n.interface.as_ref().map(|i| &i.params).into_iter().flatten() {
            props.insert(name.clone(), built_in_param_schema(&format!("sets {}", targets.join(", ")), "free"));
        }
        per_type.push(one_type(entry.name, n.description.as_deref().unwrap_or(""), props));
    }
    if let Some(component) = schema.pointer_mut("/$defs/Component") {
        component["properties"]["type"]["enum"] = json!(types);
        component["allOf"] = json!(per_type);
    }
    // an input binds to ports or to a parameter, and names are identifiers (as `graph` checks)
    if let Some(input) = schema.pointer_mut("/$defs/InputDecl") {
        input["oneOf"] = json!([{ "required": ["port"] }, { "required": ["parameter"] }]);
    }
    if let Some(interface) = schema.pointer_mut("/$defs/Interface/properties") {
        for key in ["inputs", "outputs"] {
            interface[key]["propertyNames"] = json!({ "pattern": "^[A-Za-z_][A-Za-z0-9_]*$" });
        }
    }
    schema
}

/// Schema of a built-in component's parameter: a number (SI), a text with
/// unit or an expression, described with its default.
fn built_in_param_schema(doc: &str, default: &str) -> serde_json::Value {
    serde_json::json!({ "description": format!("{doc} (default {default})"), "anyOf": [{ "type": "number" }, { "type": "string" }] })
}

/// A parameter's default as written in the built-in's netlist.
fn default_text(v: &Value) -> String {
    match v {
        Value::Number(x) => x.to_string(),
        Value::Text(t) => t.clone(),
        Value::List(_) => "a list".to_string(),
    }
}

/// Schema of one block parameter: a number (SI), a text with unit or an
/// expression ("= ..."), or one of the words of a choice.
fn param_schema(p: &blocks::params::ParamSpec) -> serde_json::Value {
    use blocks::params::ParamKind;
    use serde_json::json;
    let unit = if p.display_unit.is_empty() { String::new() } else { format!(" [{}]", p.display_unit) };
    let default = match (p.default, p.kind) {
        (None, _) => " (required)".to_string(),
        (Some(d), ParamKind::Choice(options)) => format!(" (default {})", options.get(d as usize).copied().unwrap_or("")),
        (Some(d), _) if d.is_infinite() => " (default inf)".to_string(),
        (Some(d), _) if p.display_unit.is_empty() => format!(" (default {d})"),
        (Some(d), _) => format!(
            " (default {} {})",
            units::to_unit(d, p.display_unit).map(|v| format!("{v:.6e}").parse::<f64>().unwrap_or(v)).unwrap_or(d),
            p.display_unit
        ),
    };
    let description = format!("{}{unit}{default}", p.doc);
    match p.kind {
        ParamKind::Choice(options) => json!({ "description": description, "enum": options }),
        ParamKind::List(_) => {
            json!({ "description": description, "anyOf": [{ "type": "array" }, { "type": "string" }, { "type": "number" }] })
        }
        ParamKind::Words => {
            let description = format!("{}{}", p.doc, if p.default.is_none() { " (required)" } else { "" });
            json!({ "description": description, "anyOf": [{ "type": "array", "items": { "type": "string" } }, { "type": "string" }] })
        }
        _ => json!({ "description": description, "anyOf": [{ "type": "number" }, { "type": "string" }] }),
    }
}
