//! Named parameters and expressions, resolved once per build.
//!
//! A netlist may declare `parameters` and write any component parameter or
//! initial value as an expression: `"p0": "= supply.p"`,
//! `"dead_volume": "= 2 * V_port"`, `"area": "= pi/4 * bore^2"` (syntax in
//! [`units::expr`]). Resolution:
//!
//! 1. every value becomes a *slot*: a named parameter (`bore`, `cyl.bore`),
//!    or a component's parameter (`rod.p0`), written or defaulted;
//! 2. names in an expression are looked up in the scope it was written in
//!    (the top level, or the subsystem instance `cyl` for values inside
//!    `lib/cylinder.json`): `bore` in scope `cyl` is the slot `cyl.bore`;
//!    an interface parameter of a subsystem (`cyl.T0`) reads its first target;
//! 3. slots are ordered by their references (petgraph toposort; a cycle is an
//!    error naming it) and evaluated once each, with the dimension checked
//!    against the block's declaration (a pressure where a length is expected
//!    is an error);
//! 4. the result is a netlist in which every expression is replaced by its SI
//!    number, so that `--set`, sweeps and manifests, which edit the written
//!    values, move everything that depends on them: resolution always runs
//!    after the last edit, inside [`crate::build`].
//!
//! Plain numbers are SI. A plain number given for a quantity whose usual unit
//! is not SI-coherent (`"p": 6` for a pressure shown in bar) is accepted with
//! a [`Warning`], because it is almost always a forgotten unit.

use crate::expand::FlatNetlist;
use crate::netlist::Value;
use crate::{escape, GraphError, Warning};
use blocks::params::{parse_value, ParamKind};
use petgraph::graph::{DiGraph, NodeIndex};
use std::collections::BTreeMap;
use units::expr::{parse_expr, Expr, Quantity};
use units::{dim, Dimension};

/// Whether `name` may name a netlist parameter: an identifier, not `pi`.
pub fn valid_parameter_name(name: &str) -> bool {
    let mut chars = name.chars();
    name.len() <= crate::MAX_NAME_CHARS
        && matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && name != "pi"
}

/// Where a resolved value came from.
#[derive(Debug, Clone, PartialEq)]
pub enum SlotKind {
    /// A declared parameter (`bore`, `cyl.bore`).
    Parameter { description: Option<String> },
    /// A component parameter or initial value written in the netlist.
    Written,
    /// A component parameter left at its block default.
    Default,
}

/// One resolved value.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedValue {
    /// Value in SI (absolute).
    pub si: f64,
    pub dim: Dimension,
    /// Unit to show it in ("bar", "mm"; "" for SI or dimensionless).
    pub display_unit: String,
    /// The expression it was computed from, if any (without the '=').
    pub expression: Option<String>,
    pub kind: SlotKind,
    /// File that wrote it.
    pub origin: String,
}

impl ResolvedValue {
    /// Whether the value was derived from an expression.
    pub fn derived(&self) -> bool {
        self.expression.is_some()
    }
}

/// All values of a netlist, resolved.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Resolved {
    /// Full name (`bore`, `rod.p0`, `cyl.piston.mass`) → value.
    pub values: BTreeMap<String, ResolvedValue>,
    /// Questionable but accepted input, one line each.
    pub warnings: Vec<Warning>,
}

impl Resolved {
    pub fn get(&self, name: &str) -> Option<&ResolvedValue> {
        self.values.get(name)
    }
}

/// What a slot holds before evaluation.
enum Source {
    Expr {
        expr: Expr,
        text: String,
        scope: String,
    },
    /// A literal already in SI (plain number or text with unit parsed against its spec).
    Literal(f64),
    /// A choice or list parameter: not usable in expressions.
    NotNumeric(&'static str),
}

struct Slot {
    name: String,
    /// `component "rod", parameter "p0"` or `parameter "bore"`.
    subject: String,
    origin: String,
    source: Source,
    /// Dimension a component parameter must have (None: a named parameter takes whatever it is given).
    expected: Option<(Dimension, ParamKind)>,
    kind: SlotKind,
    display_unit: String,
}

fn expression_text(v: &Value) -> Option<&str> {
    match v {
        Value::Text(s) if units::expr::is_expression(s) => Some(s.trim_start().trim_start_matches('=').trim()),
        _ => None,
    }
}

fn param_error(slot_origin: &str, subject: &str, message: String) -> GraphError {
    GraphError::Parameter { file: slot_origin.to_string(), subject: subject.to_string(), message }
}

/// Whether a unit is SI-coherent (factor 1, no offset), so that a plain number means the same.
fn is_si_unit(unit: &str) -> bool {
    unit.is_empty() || units::parse_unit(unit).map(|u| u.factor == 1.0 && u.offset == 0.0).unwrap_or(true)
}

/// SI unit symbol of a dimension, for messages ("Pa"; "" if dimensionless).
pub fn si_unit(d: Dimension) -> String {
    if d == dim::DIMENSIONLESS {
        return String::new();
    }
    d.example_units().first().map(|s| s.to_string()).unwrap_or_else(|| d.name())
}

/// Build the slots of a flat netlist.
fn slots(flat: &FlatNetlist, warnings: &mut Vec<Warning>) -> Result<Vec<Slot>, GraphError> {
    let mut out = Vec::new();
    for p in &flat.parameters {
        let subject = format!("parameter \"{}\"", p.name);
        let kind = SlotKind::Parameter { description: p.description.clone() };
        let (source, expected, display_unit) = match &p.value {
            // a plain number keeps the dimension the file gave the parameter (an override such as `--set bore=0.05`)
            Value::Number(x) => {
                let d = p.declared_dim.unwrap_or(dim::DIMENSIONLESS);
                if d != dim::DIMENSIONLESS {
                    warnings.push(bare_number_warning(&p.origin, &p.name, *x, d, &p.declared_unit));
                }
                (Source::Literal(*x), Some(d), String::new())
            }
            Value::Text(t) => match expression_text(&p.value) {
                Some(text) => {
                    let expr = parse_expr(text).map_err(|e| param_error(&p.origin, &subject, format!("\"{}\": {e}", escape(text))))?;
                    (Source::Expr { expr, text: text.to_string(), scope: p.scope.clone() }, None, String::new())
                }
                None => {
                    let mut q = literal(t).map_err(|e| param_error(&p.origin, &subject, e))?;
                    if q.value.is_infinite() && q.dim == dim::DIMENSIONLESS {
                        // "inf" fits any dimension: keep the one the file gave
                        q.dim = p.declared_dim.unwrap_or(dim::DIMENSIONLESS);
                    }
                    (Source::Literal(q.value), Some(q.dim), literal_unit(t))
                }
            },
            Value::List(_) => return Err(param_error(&p.origin, &subject, "a parameter holds one value, not a list".into())),
        };
        let expected = expected.map(|d| (d, ParamKind::Quantity(d)));
        out.push(Slot { name: p.name.clone(), subject, origin: p.origin.clone(), source, expected, kind, display_unit });
    }
    for c in &flat.components {
        let Ok(ty) = blocks::registry::block_type(&c.kind) else {
            continue; // `build` reports the unknown type with its id
        };
        for spec in ty.params {
            let name = format!("{}.{}", c.id, spec.name);
            let subject = format!("component \"{}\", parameter \"{}\"", c.id, spec.name);
            let written = c.value(spec.name);
            let kind = if written.is_some() { SlotKind::Written } else { SlotKind::Default };
            let expected = match spec.kind {
                ParamKind::Quantity(d) | ParamKind::List(d) => Some((d, spec.kind)),
                ParamKind::Count => Some((dim::DIMENSIONLESS, spec.kind)),
                ParamKind::Choice(_) | ParamKind::Words => None,
            };
            let source = match (written, spec.kind) {
                (_, ParamKind::Choice(_)) => Source::NotNumeric("a choice"),
                (_, ParamKind::Words) => Source::NotNumeric("text"),
                (Some(v), ParamKind::List(_)) if expression_text(v).is_some() => {
                    return Err(param_error(&c.origin, &subject, "a list parameter cannot be an expression".into()))
                }
                (_, ParamKind::List(_)) => Source::NotNumeric("a list"),
                (Some(v), _) => match expression_text(v) {
                    Some(text) => {
                        let expr = parse_expr(text).map_err(|e| param_error(&c.origin, &subject, format!("\"{}\": {e}", escape(text))))?;
                        Source::Expr { expr, text: text.to_string(), scope: c.scope_of(spec.name).to_string() }
                    }
                    None => {
                        let x = parse_value(spec, &v.to_raw()).map_err(|source| GraphError::Block {
                            file: c.origin.clone(),
                            id: c.id.clone(),
                            source: Box::new(blocks::BlockError::Param(source)),
                        })?;
                        if let (Value::Number(n), ParamKind::Quantity(d)) = (v, spec.kind) {
                            if !is_si_unit(spec.display_unit) {
                                warnings.push(bare_number_warning(&c.origin, &name, *n, d, spec.display_unit));
                            }
                        }
                        Source::Literal(x)
                    }
                },
                (None, _) => match spec.default {
                    Some(d) => Source::Literal(d),
                    None => continue, // required and missing: `build` reports it
                },
            };
            out.push(Slot { name, subject, origin: c.origin.clone(), source, expected, kind, display_unit: spec.display_unit.to_string() });
        }
    }
    Ok(out)
}

fn bare_number_warning(origin: &str, name: &str, x: f64, d: Dimension, usual_unit: &str) -> Warning {
    let x = units::show::num(x);
    let hint = if usual_unit.is_empty() || is_si_unit(usual_unit) {
        String::new()
    } else {
        format!("; write \"{x} {usual_unit}\" if you meant {usual_unit}")
    };
    Warning { file: origin.to_string(), message: format!("{name} = {x} is taken as {x} {} (SI){hint}", si_unit(d)) }
}

/// The unit word of a literal such as "45 mm" (for display), or "".
pub(crate) fn literal_unit(text: &str) -> String {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'))).unwrap_or(t.len());
    let unit = t[split..].trim().trim_start_matches('[').trim_end_matches(']').trim();
    // "1e-5" splits inside the number when the exponent is followed by nothing else
    if t[..split].parse::<f64>().is_err() {
        return String::new();
    }
    if units::parse_unit(unit).is_ok() {
        unit.to_string()
    } else {
        String::new()
    }
}

/// Resolve every value of `flat` (see the module documentation).
pub fn resolve(flat: &FlatNetlist) -> Result<Resolved, GraphError> {
    let mut warnings = Vec::new();
    let slots = slots(flat, &mut warnings)?;
    let index: BTreeMap<&str, usize> = slots.iter().enumerate().map(|(i, s)| (s.name.as_str(), i)).collect();
    // name written in `scope` → slot index
    let lookup = |scope: &str, name: &str| -> Option<usize> {
        let full = if scope.is_empty() { name.to_string() } else { format!("{scope}.{name}") };
        if let Some(&i) = index.get(full.as_str()) {
            return Some(i);
        }
        let target = flat.aliases.get(&full)?.first()?;
        index.get(target.as_str()).copied()
    };

    // dependency graph: edge from a referenced slot to the slot using it
    let mut graph = DiGraph::<usize, ()>::with_capacity(slots.len(), slots.len());
    let nodes: Vec<NodeIndex> = (0..slots.len()).map(|i| graph.add_node(i)).collect();
    let mut refs: Vec<BTreeMap<String, usize>> = vec![BTreeMap::new(); slots.len()];
    for (i, slot) in slots.iter().enumerate() {
        let Source::Expr { expr, text, scope } = &slot.source else { continue };
        for name in expr.names() {
            if name == "pi" {
                continue;
            }
            let j = lookup(scope, &name).ok_or_else(|| {
                param_error(&slot.origin, &slot.subject, format!("\"{}\": {}", escape(text), unknown_name(&name, scope, &slots)))
            })?;
            refs[i].insert(name, j);
            graph.update_edge(nodes[j], nodes[i], ());
        }
    }
    let order = petgraph::algo::toposort(&graph, None).map_err(|cycle| {
        let start = graph[cycle.node_id()];
        GraphError::ParameterCycle { file: slots[start].origin.clone(), cycle: describe_cycle(&graph, &nodes, &slots, start) }
    })?;

    let mut values: Vec<Option<Quantity>> = vec![None; slots.len()];
    for node in order {
        let i = graph[node];
        let slot = &slots[i];
        let q = match &slot.source {
            Source::Literal(x) => {
                let d = slot.expected.map(|(d, _)| d).unwrap_or(dim::DIMENSIONLESS);
                Quantity { value: *x, dim: d }
            }
            Source::NotNumeric(_) => continue,
            Source::Expr { text, .. } if refs[i].len() == 1 && refs[i].contains_key(text.as_str()) => {
                // "= name": the value itself, whatever it is ("inf" included)
                let j = refs[i][text.as_str()];
                let q = values[j].ok_or_else(|| {
                    let what = match &slots[j].source {
                        Source::NotNumeric(what) => what,
                        _ => "not a number",
                    };
                    param_error(&slot.origin, &slot.subject, format!("\"{}\" is {what}, not a number", escape(text)))
                })?;
                check_dimension(slot, text, q)?;
                q
            }
            Source::Expr { expr, text, .. } => {
                let mut failed: Option<String> = None;
                let q = expr
                    .eval(&mut |name: &str| {
                        let j = *refs[i].get(name)?;
                        match (&values[j], &slots[j].source) {
                            (Some(q), _) => Some(*q),
                            (None, Source::NotNumeric(what)) => {
                                failed = Some(format!("\"{name}\" is {what}, not a number"));
                                None
                            }
                            (None, _) => None,
                        }
                    })
                    .map_err(|e| {
                        let why = failed.take().unwrap_or_else(|| e.to_string());
                        param_error(&slot.origin, &slot.subject, format!("\"{}\": {why}", escape(text)))
                    })?;
                check_dimension(slot, text, q)?;
                q
            }
        };
        values[i] = Some(q);
    }

    let mut out = Resolved { values: BTreeMap::new(), warnings };
    for (i, slot) in slots.iter().enumerate() {
        let Some(q) = values[i] else { continue };
        let expression = match &slot.source {
            Source::Expr { text, .. } => Some(text.clone()),
            _ => None,
        };
        out.values.insert(
            slot.name.clone(),
            ResolvedValue {
                si: q.value,
                dim: q.dim,
                display_unit: slot.display_unit.clone(),
                expression,
                kind: slot.kind.clone(),
                origin: slot.origin.clone(),
            },
        );
    }
    Ok(out)
}

/// A component value must have the dimension its block declares (a count: a whole number).
fn check_dimension(slot: &Slot, text: &str, q: Quantity) -> Result<(), GraphError> {
    let Some((want, kind)) = slot.expected else { return Ok(()) };
    if q.dim != want && !(q.value.is_infinite() && q.dim == dim::DIMENSIONLESS) {
        return Err(param_error(
            &slot.origin,
            &slot.subject,
            format!("\"= {}\" is {}, but the parameter is {}", escape(text), article(q.dim), article(want)),
        ));
    }
    if kind == ParamKind::Count && (q.value < 0.0 || q.value.fract() != 0.0) {
        return Err(param_error(
            &slot.origin,
            &slot.subject,
            format!("\"= {}\" = {} is not a whole number >= 0", escape(text), units::show::num(q.value)),
        ));
    }
    Ok(())
}

fn article(d: Dimension) -> String {
    if d == dim::DIMENSIONLESS {
        "a plain number (write a unit, e.g. \"* 1 bar\")".to_string()
    } else {
        d.with_article()
    }
}

fn unknown_name(name: &str, scope: &str, slots: &[Slot]) -> String {
    let full = if scope.is_empty() { name.to_string() } else { format!("{scope}.{name}") };
    let prefix = if scope.is_empty() { String::new() } else { format!("{scope}.") };
    // suggest names of the same scope that share the last segment or start the same way
    let last = name.rsplit('.').next().unwrap_or(name);
    let mut near: Vec<&str> = slots
        .iter()
        .filter_map(|s| s.name.strip_prefix(prefix.as_str()))
        .filter(|n| n.rsplit('.').next() == Some(last) || (last.len() >= 2 && n.starts_with(&last[..2])))
        .take(5)
        .collect();
    near.sort();
    let scope_note = if scope.is_empty() { String::new() } else { format!(" (inside \"{scope}\")") };
    if near.is_empty() {
        format!("unknown name \"{}\"{scope_note}", escape(&full))
    } else {
        format!("unknown name \"{}\"{scope_note}; did you mean {}?", escape(name), near.join(", "))
    }
}

/// "a -> b -> a" for a cycle through `start`.
fn describe_cycle(graph: &DiGraph<usize, ()>, nodes: &[NodeIndex], slots: &[Slot], start: usize) -> String {
    // breadth-first search from start's successors back to start
    let mut prev: BTreeMap<NodeIndex, NodeIndex> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([nodes[start]]);
    let mut found = false;
    while let Some(n) = queue.pop_front() {
        for m in graph.neighbors(n) {
            if m == nodes[start] {
                prev.insert(m, n);
                found = true;
                break;
            }
            if let std::collections::btree_map::Entry::Vacant(e) = prev.entry(m) {
                e.insert(n);
                queue.push_back(m);
            }
        }
        if found {
            break;
        }
    }
    let mut path = vec![nodes[start]];
    let mut n = nodes[start];
    while let Some(&p) = prev.get(&n) {
        if p == nodes[start] || path.len() > slots.len() {
            break;
        }
        path.push(p);
        n = p;
    }
    path.push(nodes[start]);
    path.reverse();
    path.iter().map(|&n| slots[graph[n]].name.as_str()).collect::<Vec<_>>().join(" -> ")
}

/// `flat` with every expression replaced by its SI number, and the resolution.
pub fn concrete(flat: &FlatNetlist) -> Result<(FlatNetlist, Resolved), GraphError> {
    let resolved = resolve(flat)?;
    let mut out = flat.clone();
    for c in out.components.iter_mut() {
        for (param, value) in c.params.iter_mut().chain(c.init.iter_mut()) {
            if expression_text(value).is_some() {
                if let Some(v) = resolved.values.get(&format!("{}.{param}", c.id)) {
                    *value = Value::Number(v.si);
                }
            }
        }
    }
    Ok((out, resolved))
}

/// A literal parameter value without names ("45 mm", "50 N s/m", "0.3",
/// "= 2 * 3 mm" is not a literal), in SI with its dimension.
pub fn literal(text: &str) -> Result<Quantity, String> {
    let t = text.trim();
    // "inf" (an adiabatic wall's tau_thermal), optionally with a unit: "inf s"
    for word in ["infinity", "inf", "∞"] {
        if let Some(rest) = t.strip_prefix(word) {
            let unit = rest.trim();
            if unit.is_empty() {
                return Ok(Quantity { value: f64::INFINITY, dim: dim::DIMENSIONLESS });
            }
            if let Ok(u) = units::parse_unit(unit) {
                return Ok(Quantity { value: f64::INFINITY, dim: u.dimension });
            }
        }
    }
    // a number followed by a unit text, which may have several words ("50 N s/m")
    let split = t
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || ((c == 'e' || c == 'E') && i > 0)
                || ((c == '+' || c == '-') && (i == 0 || matches!(t.as_bytes()[i - 1], b'e' | b'E'))))
        })
        .map(|(i, _)| i)
        .unwrap_or(t.len());
    if let Ok(x) = t[..split].parse::<f64>() {
        // a run of digits beyond f64 is refused, quoting the input shortened
        // ("inf" itself was taken above)
        if !x.is_finite() {
            return Err(units::UnitError::NonFinite { text: t.to_string() }.to_string());
        }
        let unit = t[split..].trim();
        if unit.is_empty() {
            return Ok(Quantity { value: x, dim: dim::DIMENSIONLESS });
        }
        if let Ok(u) = units::parse_unit(unit) {
            return Ok(Quantity { value: u.to_si(x), dim: u.dimension });
        }
    }
    let e = parse_expr(t).map_err(|e| format!("\"{}\": {e}", escape(t)))?;
    e.eval(&mut |_| None).map_err(|e| format!("\"{}\": {e}", escape(t)))
}
