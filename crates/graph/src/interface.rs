//! The model interface of a netlist: inputs set from outside and outputs
//! reported to it, bound to the blocks of the circuit being built.
//!
//! The format is the `interface` section's `inputs` and `outputs`
//! ([`crate::netlist::InputDecl`], [`crate::netlist::OutputDecl`];
//! docs/netlist.md, "Model interface"). Front ends that drive a model from
//! outside — the FMU runtime, linearisation — read the bound interface from
//! [`crate::Circuit::interface`]:
//!
//! - an input bound to signal **ports** gets a source block
//!   ([`blocks::external_input`]) whose output feeds those ports; its value
//!   is the source's live parameter. With [`Drive::External`] it replaces
//!   whatever the netlist connects to the ports (the cycler that drives a
//!   valve, the PID that drives a proportional valve); with
//!   [`Drive::Standalone`] a connected port keeps its connection, and only a
//!   port nothing drives reads the input (at its start value);
//! - an input bound to a **parameter** sets a live parameter of a block
//!   ([`blocks::Block::live_parameters`]: a supply pressure, an external
//!   force); it starts at the parameter's value;
//! - an output names a recorded value: a signal output, a block's recorded
//!   output, or a running total (a block quadrature such as the mass a
//!   supply delivered).
//!
//! Values are SI inside; each input and output carries the unit it has
//! outside ([`OuterUnit`]). Names are identifiers, unique among the inputs,
//! the outputs and the netlist's top-level parameters (an FMU lists all
//! three as variables of one namespace).

use crate::circuit::{Instance, PortRef};
use crate::expand::FlatNetlist;
use crate::netlist::{split_ref, InputDecl, Value};
use crate::params::Resolved;
use crate::{escape, GraphError};
use blocks::block::PortKind;
use blocks::params::{ParamKind, ParamSpec};
use std::collections::{BTreeMap, BTreeSet};
use units::Dimension;

/// How the interface's inputs act on the circuit being built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Drive {
    /// The netlist runs by itself (`pneumo simulate`, sweeps): a port an
    /// input is bound to keeps the signal the netlist connects to it; a port
    /// nothing drives reads the input's start value.
    #[default]
    Standalone,
    /// The inputs are set from outside (an FMU, a linearisation): every
    /// bound port reads its input, whatever the netlist connects to it.
    External,
}

/// The unit a value has outside: SI = value · `factor` + `offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct OuterUnit {
    /// As written ("bar", "mm", "degC"), or the SI unit of the bound value
    /// ("Pa", "m", "1"); "" when the value has no fixed dimension.
    pub text: String,
    pub factor: f64,
    pub offset: f64,
    /// Dimension of the value (`None` for a signal that carries whatever its source carries).
    pub dim: Option<Dimension>,
}

impl OuterUnit {
    /// SI value of `value` given in this unit.
    pub fn to_si(&self, value: f64) -> f64 {
        value * self.factor + self.offset
    }
    /// Value in this unit of the SI value `si`.
    pub fn from_si(&self, si: f64) -> f64 {
        (si - self.offset) / self.factor
    }
}

/// What an input is bound to, as the netlist writes it.
#[derive(Debug, Clone, PartialEq)]
pub enum Binding {
    /// Signal input ports ("dcv.command").
    Ports(Vec<String>),
    /// A live block parameter ("supply.p").
    Parameter(String),
}

/// Where an input's value goes in the built circuit: a live parameter of one block.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveTarget {
    /// Index of the block in [`crate::Circuit::instances`].
    pub block: usize,
    /// The live parameter it sets ([`blocks::Block::set_live_parameter`]).
    pub param: &'static str,
    /// The parameter's declaration, whose range a new value must respect
    /// (`None` for the source of a port input, which takes any finite value).
    pub spec: Option<ParamSpec>,
}

/// A bound model input.
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    pub name: String,
    pub description: Option<String>,
    pub unit: OuterUnit,
    /// Value until one is set from outside [SI].
    pub start: f64,
    pub binding: Binding,
    /// Where the value goes; `None` when the input acts on nothing in this
    /// circuit (a standalone run in which the netlist drives every bound port).
    pub live: Option<LiveTarget>,
}

/// Which recorded value an output reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputSource {
    /// The `index`-th signal output of block `block`.
    Signal { block: usize, index: usize },
    /// The `index`-th recorded output ([`blocks::Block::outputs`]).
    Recorded { block: usize, index: usize },
    /// The `index`-th running total ([`blocks::Block::quadratures`]), integrated from t = 0.
    Quadrature { block: usize, index: usize },
}

/// A bound model output.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    pub name: String,
    pub description: Option<String>,
    pub unit: OuterUnit,
    /// The recorded value as written ("piston.x").
    pub from: String,
    pub source: OutputSource,
}

/// The bound interface of a circuit (empty when the netlist declares none).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelInterface {
    pub inputs: Vec<Input>,
    pub outputs: Vec<Output>,
}

impl ModelInterface {
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty() && self.outputs.is_empty()
    }
    pub fn input(&self, name: &str) -> Option<&Input> {
        self.inputs.iter().find(|i| i.name == name)
    }
    pub fn output(&self, name: &str) -> Option<&Output> {
        self.outputs.iter().find(|o| o.name == name)
    }
}

/// Id of the source block of port input `name`.
pub fn source_id(name: &str) -> String {
    format!("input.{name}")
}

/// Inputs bound, with the signal connections they add and the ports whose
/// netlist connection they replace.
pub(crate) struct BoundInputs {
    pub inputs: Vec<Input>,
    /// (source output, driven input port) for every port an input drives.
    pub connections: Vec<(PortRef, PortRef)>,
    /// Ports whose connection in the netlist is replaced.
    pub replaced: BTreeSet<PortRef>,
}

fn error(flat: &FlatNetlist, what: &'static str, name: &str, message: String) -> GraphError {
    GraphError::Interface { file: flat.origin.clone(), what, name: escape(name), message }
}

/// Names of the top-level netlist parameters (FMU parameters share the namespace).
fn top_level_parameters(flat: &FlatNetlist) -> BTreeSet<&str> {
    flat.parameters.iter().map(|p| p.name.as_str()).filter(|n| !n.contains('.')).collect()
}

/// An interface name must be an identifier, unique among inputs, outputs and top-level parameters.
fn check_name(flat: &FlatNetlist, what: &'static str, name: &str) -> Result<(), GraphError> {
    if !crate::params::valid_parameter_name(name) {
        return Err(error(flat, what, name, "a name must be a letter or '_' followed by letters, digits or '_'".into()));
    }
    if top_level_parameters(flat).contains(name) {
        return Err(error(
            flat,
            what,
            name,
            "is also the name of a parameter of the netlist; inputs, outputs and parameters share one namespace".into(),
        ));
    }
    if what == "output" && flat.inputs.contains_key(name) {
        return Err(error(flat, what, name, "is also the name of an input".into()));
    }
    Ok(())
}

/// Dimension of a signal or recorded unit ("Pa", "1", "m3"); `None` for "" (whatever its source carries).
fn unit_dimension(unit: &str) -> Option<Dimension> {
    if unit.is_empty() {
        return None;
    }
    units::parse_unit(unit).ok().map(|u| u.dimension)
}

/// The outer unit of a value of dimension `dim` whose SI unit is `si_unit`:
/// the declared one (checked against `dim`), else the SI unit.
fn outer_unit(declared: Option<&str>, dim: Option<Dimension>, si_unit: &str) -> Result<OuterUnit, String> {
    let Some(text) = declared else {
        return Ok(OuterUnit { text: si_unit.to_string(), factor: 1.0, offset: 0.0, dim });
    };
    let unit = units::parse_unit(text).map_err(|e| format!("unit \"{}\": {e}", escape(text)))?;
    if let Some(d) = dim {
        if unit.dimension != d {
            return Err(format!(
                "unit \"{}\" is {}, but the value is {} ({})",
                escape(text),
                unit.dimension.with_article(),
                d.with_article(),
                if si_unit.is_empty() { "SI".to_string() } else { si_unit.to_string() }
            ));
        }
    }
    Ok(OuterUnit { text: text.trim().to_string(), factor: unit.factor, offset: unit.offset, dim: Some(unit.dimension) })
}

/// A port "id.port" of the built instances.
fn find_port(instances: &[Instance], reference: &str) -> Result<PortRef, String> {
    let (id, port) = split_ref(reference).ok_or_else(|| format!("\"{}\" is not of the form ID.PORT", escape(reference)))?;
    let block =
        instances.iter().position(|i| i.id == id).ok_or_else(|| format!("\"{}\": no component \"{}\"", escape(reference), escape(id)))?;
    let ports = instances[block].block.ports();
    let port = ports.iter().position(|p| p.name == port).ok_or_else(|| {
        format!("\"{}\": no such port (ports: {})", escape(reference), ports.iter().map(|p| p.name).collect::<Vec<_>>().join(", "))
    })?;
    Ok(PortRef { block, port })
}

/// Value of an input's `start`: SI number, text with unit, or an expression
/// of the netlist's resolved values.
fn start_value(value: &Value, dim: Option<Dimension>, resolved: &Resolved) -> Result<f64, String> {
    let q = match value {
        Value::Number(x) => return Ok(*x),
        Value::List(_) => return Err("start: a single value, not a list".into()),
        Value::Text(text) if units::expr::is_expression(text) => {
            let body = text.trim_start().trim_start_matches('=').trim();
            let expr = units::parse_expr(body).map_err(|e| format!("start \"{}\": {e}", escape(body)))?;
            expr.eval(&mut |name| resolved.get(name).map(|v| units::Quantity { value: v.si, dim: v.dim }))
                .map_err(|e| format!("start \"{}\": {e}", escape(body)))?
        }
        Value::Text(text) => crate::params::literal(text).map_err(|e| format!("start: {e}"))?,
    };
    match dim {
        Some(d) if q.dim != d => Err(format!("start is {}, but the input is {}", q.dim.with_article(), d.with_article())),
        _ if !q.value.is_finite() => Err("start must be finite".into()),
        _ => Ok(q.value),
    }
}

/// Bind the netlist's inputs to the built `instances`, adding one source
/// block per port input that drives anything (see the module documentation).
/// `ends` are the netlist's connections, resolved.
pub(crate) fn bind_inputs(
    flat: &FlatNetlist,
    instances: &mut Vec<Instance>,
    ends: &[(PortRef, PortRef)],
    drive: Drive,
    resolved: &Resolved,
) -> Result<BoundInputs, GraphError> {
    let kind = |instances: &[Instance], r: PortRef| instances[r.block].block.ports()[r.port].kind;
    // signal input ports the netlist drives
    let connected: BTreeSet<PortRef> =
        ends.iter().flat_map(|&(a, b)| [a, b]).filter(|&r| kind(instances, r) == PortKind::SignalIn).collect();
    let mut out = BoundInputs { inputs: Vec::new(), connections: Vec::new(), replaced: BTreeSet::new() };
    let mut taken_ports: BTreeMap<PortRef, &str> = BTreeMap::new();
    let mut taken_params: BTreeMap<String, &str> = BTreeMap::new();
    for (name, decl) in &flat.inputs {
        check_name(flat, "input", name)?;
        let fail = |message: String| error(flat, "input", name, message);
        let input = match (&decl.port, &decl.parameter) {
            (Some(ports), None) => {
                let refs = ports.ports();
                if refs.is_empty() {
                    return Err(fail("\"port\" lists no port".into()));
                }
                let mut bound = Vec::new();
                let mut port_dim: Option<(Dimension, &str)> = None;
                for reference in &refs {
                    let r = find_port(instances, reference).map_err(&fail)?;
                    let spec = &instances[r.block].block.ports()[r.port];
                    if spec.kind != PortKind::SignalIn {
                        let what = match spec.kind {
                            PortKind::SignalOut => "a signal output".to_string(),
                            k => format!("a {} port", k.domain()),
                        };
                        return Err(fail(format!(
                            "\"{}\" is {what}; an input drives signal input ports (or a live parameter, with \"parameter\")",
                            escape(reference)
                        )));
                    }
                    if let Some(other) = taken_ports.insert(r, name) {
                        return Err(fail(format!("port \"{}\" is already driven by input \"{}\"", escape(reference), escape(other))));
                    }
                    if let Some(d) = unit_dimension(spec.unit) {
                        match port_dim {
                            Some((d0, u0)) if d0 != d => {
                                return Err(fail(format!("its ports carry different quantities ({u0} and {})", spec.unit)));
                            }
                            _ => port_dim = Some((d, spec.unit)),
                        }
                    }
                    bound.push(r);
                }
                let si_unit = port_dim.map(|(_, u)| u).unwrap_or("");
                let unit = outer_unit(decl.unit.as_deref(), port_dim.map(|(d, _)| d), si_unit).map_err(&fail)?;
                let start = match &decl.start {
                    Some(v) => start_value(v, unit.dim, resolved).map_err(&fail)?,
                    None => 0.0,
                };
                let drives: Vec<PortRef> = bound.iter().copied().filter(|r| drive == Drive::External || !connected.contains(r)).collect();
                let live = if drives.is_empty() {
                    None
                } else {
                    let id = source_id(name);
                    if instances.iter().any(|i| i.id == id) {
                        return Err(fail(format!("its source block would be called \"{id}\", which is the id of a component")));
                    }
                    instances.push(Instance {
                        id,
                        block: blocks::external_input::external_input(start),
                        port_nodes: vec![None],
                        signal_sources: Vec::new(),
                    });
                    let source = PortRef { block: instances.len() - 1, port: 0 };
                    for &r in &drives {
                        out.connections.push((source, r));
                        if connected.contains(&r) {
                            out.replaced.insert(r);
                        }
                    }
                    Some(LiveTarget { block: source.block, param: blocks::external_input::VALUE, spec: None })
                };
                let binding = Binding::Ports(refs.iter().map(|s| s.to_string()).collect());
                Input { name: name.clone(), description: decl.description.clone(), unit, start, binding, live }
            }
            (None, Some(reference)) => bind_parameter(flat, instances, name, decl, reference, resolved, &mut taken_params)?,
            _ => return Err(fail("give either \"port\" (signal input ports) or \"parameter\" (a live block parameter)".into())),
        };
        out.inputs.push(input);
    }
    Ok(out)
}

/// An input bound to a live parameter "id.param".
fn bind_parameter<'a>(
    flat: &FlatNetlist,
    instances: &[Instance],
    name: &'a str,
    decl: &InputDecl,
    reference: &str,
    resolved: &Resolved,
    taken: &mut BTreeMap<String, &'a str>,
) -> Result<Input, GraphError> {
    let fail = |message: String| error(flat, "input", name, message);
    let (id, param) = split_ref(reference).ok_or_else(|| fail(format!("\"{}\" is not of the form ID.PARAMETER", escape(reference))))?;
    let block = instances
        .iter()
        .position(|i| i.id == id)
        .ok_or_else(|| fail(format!("\"{}\": no component \"{}\"", escape(reference), escape(id))))?;
    let live = instances[block].block.live_parameters();
    let Some(&param) = live.iter().find(|p| **p == param) else {
        let known = if live.is_empty() { "it has none".to_string() } else { format!("those of \"{id}\": {}", live.join(", ")) };
        return Err(fail(format!("\"{}\" cannot change during a run; an input may set a live parameter ({known})", escape(reference))));
    };
    if let Some(other) = taken.insert(reference.to_string(), name) {
        return Err(fail(format!("parameter \"{}\" is already set by input \"{}\"", escape(reference), escape(other))));
    }
    if decl.start.is_some() {
        return Err(fail(format!(
            "a parameter input starts at the parameter's value: give \"{}\" its value instead of \"start\"",
            escape(reference)
        )));
    }
    let component = flat.component(id).ok_or_else(|| fail(format!("\"{}\": no component \"{}\"", escape(reference), escape(id))))?;
    let spec = blocks::registry::block_type(&component.kind)
        .ok()
        .and_then(|t| t.params.iter().find(|s| s.name == param).copied())
        .ok_or_else(|| fail(format!("\"{}\": the block declares no such parameter", escape(reference))))?;
    let ParamKind::Quantity(d) = spec.kind else {
        return Err(fail(format!("\"{}\" is not a quantity", escape(reference))));
    };
    let unit = outer_unit(decl.unit.as_deref(), Some(d), &crate::params::si_unit(d)).map_err(&fail)?;
    let start = resolved.get(reference).map(|v| v.si).ok_or_else(|| fail(format!("\"{}\" has no value", escape(reference))))?;
    Ok(Input {
        name: name.to_string(),
        description: decl.description.clone(),
        unit,
        start,
        binding: Binding::Parameter(reference.to_string()),
        live: Some(LiveTarget { block, param, spec: Some(spec) }),
    })
}

/// Bind the netlist's outputs to recorded values of the built `instances`.
pub(crate) fn bind_outputs(flat: &FlatNetlist, instances: &[Instance]) -> Result<Vec<Output>, GraphError> {
    let mut out = Vec::new();
    for (name, decl) in &flat.outputs {
        check_name(flat, "output", name)?;
        let fail = |message: String| error(flat, "output", name, message);
        let from = decl.from();
        let (source, si_unit) = find_recorded(instances, from).map_err(&fail)?;
        let unit = outer_unit(decl.unit(), unit_dimension(si_unit), si_unit).map_err(&fail)?;
        out.push(Output { name: name.clone(), description: decl.description().map(str::to_string), unit, from: from.to_string(), source });
    }
    Ok(out)
}

/// A recorded value "id.name" and its SI unit.
fn find_recorded(instances: &[Instance], reference: &str) -> Result<(OutputSource, &'static str), String> {
    let (id, name) = split_ref(reference).ok_or_else(|| format!("\"{}\" is not of the form ID.SIGNAL", escape(reference)))?;
    let block =
        instances.iter().position(|i| i.id == id).ok_or_else(|| format!("\"{}\": no component \"{}\"", escape(reference), escape(id)))?;
    let b = &instances[block].block;
    let signals: Vec<_> = b.ports().iter().filter(|p| p.kind == PortKind::SignalOut).collect();
    if let Some(index) = signals.iter().position(|p| p.name == name) {
        return Ok((OutputSource::Signal { block, index }, signals[index].unit));
    }
    if let Some(index) = b.outputs().iter().position(|o| o.name == name) {
        return Ok((OutputSource::Recorded { block, index }, b.outputs()[index].unit));
    }
    if let Some(index) = b.quadratures().iter().position(|o| o.name == name) {
        return Ok((OutputSource::Quadrature { block, index }, b.quadratures()[index].unit));
    }
    let known: Vec<&str> =
        signals.iter().map(|p| p.name).chain(b.outputs().iter().map(|o| o.name)).chain(b.quadratures().iter().map(|o| o.name)).collect();
    Err(format!(
        "\"{}\": \"{}\" records no \"{}\" (it records: {})",
        escape(reference),
        escape(id),
        escape(name),
        if known.is_empty() { "nothing".to_string() } else { known.join(", ") }
    ))
}
