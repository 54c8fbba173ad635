//! Reading and editing a flat netlist programmatically: parameter values in
//! SI, the roles of the components of a cylinder circuit, node membership of
//! ports, fresh component ids.
//!
//! No physics here. Values are read the way `graph::build` reads them: a
//! component's `params` and `init` maps, parsed against the block type's
//! declarations ([`blocks::registry`]), falling back to the declared default.
//! Units: SI throughout (a written value "20 cm3" reads as 2e-5 m³).
//!
//! Assumptions of [`Topology::of`]: a cylinder is recognised by its two
//! chambers whose `piston` port is wired (orientation `extend` = head side,
//! `retract` = rod side); the directional valve is the first `valve_*`
//! component; the supply is the pressure source on the valve's `P` node.
//! Circuits with several cylinders use the first one found.

use blocks::params::{parse_value, ParamKind, ParamSpec};
use graph::netlist::{Component, Value};
use graph::FlatNetlist;
use std::collections::BTreeMap;

/// Why a netlist could not be read or edited as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    #[error("no component \"{0}\"")]
    NoComponent(String),
    #[error("\"{target}\": {message}")]
    Param { target: String, message: String },
    #[error("{0}")]
    Topology(String),
}

/// The component with this id.
pub fn component<'a>(flat: &'a FlatNetlist, id: &str) -> Option<&'a Component> {
    flat.components.iter().find(|c| c.id == id)
}

fn component_mut<'a>(flat: &'a mut FlatNetlist, id: &str) -> Result<&'a mut Component, EditError> {
    flat.components.iter_mut().find(|c| c.id == id).ok_or_else(|| EditError::NoComponent(id.to_string()))
}

/// Declaration of parameter `param` of component `id`.
pub fn spec_of(flat: &FlatNetlist, id: &str, param: &str) -> Result<&'static ParamSpec, EditError> {
    let c = component(flat, id).ok_or_else(|| EditError::NoComponent(id.to_string()))?;
    let ty =
        blocks::registry::block_type(&c.kind).map_err(|e| EditError::Param { target: format!("{id}.{param}"), message: e.to_string() })?;
    ty.params.iter().find(|s| s.name == param).ok_or_else(|| EditError::Param {
        target: format!("{id}.{param}"),
        message: format!(
            "{} has no parameter \"{param}\" (accepted: {})",
            c.kind,
            ty.params.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
        ),
    })
}

/// Parse a written value for parameter `id.param` into SI (dimension and range checked).
pub fn parse_for(flat: &FlatNetlist, id: &str, param: &str, value: &Value) -> Result<f64, EditError> {
    let spec = spec_of(flat, id, param)?;
    if !matches!(spec.kind, ParamKind::Quantity(_)) {
        return Err(EditError::Param { target: format!("{id}.{param}"), message: "is not a numeric quantity".into() });
    }
    // bounds may lie outside the block's own range check (e.g. 0 for a C > 0): check the unit only
    let relaxed = ParamSpec { range: blocks::params::Range::Any, ..*spec };
    parse_value(&relaxed, &value.to_raw()).map_err(|e| EditError::Param { target: format!("{id}.{param}"), message: e.to_string() })
}

/// SI value of `id.param`: as written in the netlist (expressions
/// evaluated, see [`graph::params`]), else the block default.
pub fn param_si(flat: &FlatNetlist, id: &str, param: &str) -> Result<f64, EditError> {
    let spec = spec_of(flat, id, param)?;
    let target = format!("{id}.{param}");
    let c = component(flat, id).ok_or_else(|| EditError::NoComponent(id.to_string()))?;
    match c.params.get(param).or_else(|| c.init.get(param)) {
        Some(Value::Text(t)) if units::expr::is_expression(t) => {
            let resolved = graph::params::resolve(flat).map_err(|e| EditError::Param { target: target.clone(), message: e.to_string() })?;
            resolved.get(&target).map(|v| v.si).ok_or_else(|| EditError::Param { target, message: "has no value".into() })
        }
        Some(v) => parse_value(spec, &v.to_raw()).map_err(|e| EditError::Param { target, message: e.to_string() }),
        None => spec.default.ok_or_else(|| EditError::Param { target, message: "is required and not given".into() }),
    }
}

/// Whether `id.param` is written in the netlist (rather than defaulted).
pub fn is_given(flat: &FlatNetlist, id: &str, param: &str) -> bool {
    component(flat, id).is_some_and(|c| c.params.contains_key(param) || c.init.contains_key(param))
}

/// Set `id.param` to an SI number (removing any `init` entry of that name).
pub fn set_param_si(flat: &mut FlatNetlist, id: &str, param: &str, value: f64) -> Result<(), EditError> {
    spec_of(flat, id, param)?;
    let c = component_mut(flat, id)?;
    let in_init = c.init.remove(param).is_some();
    if in_init {
        c.init.insert(param.to_string(), Value::Number(value));
    } else {
        c.params.insert(param.to_string(), Value::Number(value));
    }
    Ok(())
}

/// Split "id.param" at its last dot.
pub fn split_target(target: &str) -> Result<(&str, &str), EditError> {
    graph::netlist::split_ref(target).ok_or_else(|| EditError::Param { target: target.to_string(), message: "expected ID.PARAM".into() })
}

/// An id not used yet, starting from `base` ("seal_leak", "seal_leak_2", ...).
pub fn fresh_id(flat: &FlatNetlist, base: &str) -> String {
    if component(flat, base).is_none() {
        return base.to_string();
    }
    (2..).map(|k| format!("{base}_{k}")).find(|id| component(flat, id).is_none()).unwrap_or_else(|| base.to_string())
}

/// Add a component with SI-number parameters.
pub fn add_component(flat: &mut FlatNetlist, id: &str, kind: &str, params: &[(&str, f64)], init: &[(&str, f64)]) {
    let to_map = |xs: &[(&str, f64)]| xs.iter().map(|(k, v)| (k.to_string(), Value::Number(*v))).collect::<BTreeMap<_, _>>();
    let origin = flat.origin.clone();
    flat.components.push(Component {
        id: id.to_string(),
        kind: kind.to_string(),
        file: None,
        params: to_map(params),
        init: to_map(init),
        origin,
        scopes: BTreeMap::new(),
    });
}

/// Every port on the same node as `port` (joined through connections), `port` included.
pub fn node_of(flat: &FlatNetlist, port: &str) -> Vec<String> {
    let mut members = vec![port.to_string()];
    let mut grown = true;
    while grown {
        grown = false;
        for (a, b) in &flat.connections {
            let (ha, hb) = (members.contains(a), members.contains(b));
            if ha && !hb {
                members.push(b.clone());
                grown = true;
            } else if hb && !ha {
                members.push(a.clone());
                grown = true;
            }
        }
    }
    members
}

/// The signal output that drives signal input `input` ("dcv.command" → "controller.command").
pub fn driver_of(flat: &FlatNetlist, input: &str) -> Option<String> {
    flat.connections.iter().find_map(|(a, b)| {
        if b == input {
            Some(a.clone())
        } else if a == input {
            Some(b.clone())
        } else {
            None
        }
    })
}

/// Roles of the components of a single-cylinder circuit.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Topology {
    /// Head-side chamber (volume grows on extend).
    pub head: Option<String>,
    /// Rod-side chamber.
    pub rod: Option<String>,
    /// The moving mass.
    pub piston: Option<String>,
    /// The directional valve.
    pub valve: Option<String>,
    /// The friction block.
    pub friction: Option<String>,
    /// The pressure source feeding the valve's P port.
    pub supply: Option<String>,
    /// Speed-control valves (throttles).
    pub throttles: Vec<String>,
    /// Signal output driving the valve command ("controller.command").
    pub command: Option<String>,
    /// Rigid vessels: chambers whose piston port is not wired.
    pub vessels: Vec<String>,
    /// ISO 6358 restrictions (`conductance` blocks).
    pub restrictions: Vec<String>,
}

impl Topology {
    pub fn of(flat: &FlatNetlist) -> Topology {
        let mut t = Topology::default();
        let wired = |port: &str| flat.connections.iter().any(|(a, b)| a == port || b == port);
        for c in &flat.components {
            match c.kind.as_str() {
                "chamber" if wired(&format!("{}.piston", c.id)) => {
                    let orientation = c.params.get("orientation").or_else(|| c.init.get("orientation"));
                    let retract = matches!(orientation, Some(Value::Text(s)) if s.trim().eq_ignore_ascii_case("retract"));
                    let slot = if retract { &mut t.rod } else { &mut t.head };
                    if slot.is_none() {
                        *slot = Some(c.id.clone());
                    }
                }
                "chamber" => t.vessels.push(c.id.clone()),
                "conductance" => t.restrictions.push(c.id.clone()),
                "piston" if t.piston.is_none() => t.piston = Some(c.id.clone()),
                "friction" if t.friction.is_none() => t.friction = Some(c.id.clone()),
                "speed_control_valve" => t.throttles.push(c.id.clone()),
                k if k.starts_with("valve_") && t.valve.is_none() => t.valve = Some(c.id.clone()),
                _ => {}
            }
        }
        if let Some(v) = &t.valve {
            t.command = driver_of(flat, &format!("{v}.command"));
            let node = node_of(flat, &format!("{v}.P"));
            t.supply = node.iter().filter_map(|p| graph::netlist::split_ref(p)).find_map(|(id, port)| {
                (port == "port" && component(flat, id).is_some_and(|c| c.kind == "pressure_source")).then(|| id.to_string())
            });
        }
        t
    }

    /// Both chambers of the cylinder, or an error naming what is missing.
    pub fn chambers(&self) -> Result<(&str, &str), EditError> {
        match (&self.head, &self.rod) {
            (Some(h), Some(r)) => Ok((h, r)),
            _ => Err(EditError::Topology("the circuit has no cylinder with a head-side and a rod-side chamber".into())),
        }
    }
}

/// A loader for netlists without subsystems: this crate reads no files, so
/// a netlist that names a subsystem file is refused with that file's name.
pub struct NoFiles;

impl graph::Loader for NoFiles {
    fn read(&self, path: &std::path::Path) -> Result<String, String> {
        Err(format!("no file access here ({})", path.display()))
    }
}

/// The repository's meter-out netlist, for tests.
#[cfg(test)]
pub(crate) mod tests_support {
    use graph::FlatNetlist;

    pub fn meter_out() -> FlatNetlist {
        let text = include_str!("../../../models/meter_out.json");
        let netlist = graph::expand::parse(text, "meter_out.json").expect("parse");
        graph::expand::flatten(&super::NoFiles, &netlist, std::path::Path::new("."), 0).expect("flatten")
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::meter_out;
    use super::*;

    #[test]
    fn reads_written_values_and_defaults_in_si() {
        let flat = meter_out();
        assert!((param_si(&flat, "head", "dead_volume").unwrap() - 20e-6).abs() < 1e-18);
        assert!((param_si(&flat, "flow_control", "C").unwrap() - 13.2e-3 / 60.0 / 1e5).abs() < 1e-20);
        // not written: the block default (switching_time 0, breakaway ratio 1)
        assert_eq!(param_si(&flat, "dcv", "switching_time").unwrap(), 0.0);
        assert_eq!(param_si(&flat, "friction", "breakaway_ratio").unwrap(), 1.0);
        // models/meter_out.json writes no initial state (the rest state
        // before t = 0 sets it); init values written are read like parameters
        let mut flat = flat;
        set_param_si(&mut flat, "rod", "p0", 4e5).unwrap();
        assert!((param_si(&flat, "rod", "p0").unwrap() - 4e5).abs() < 1e-9);
        assert!(param_si(&flat, "head", "nonsense").unwrap_err().to_string().contains("accepted"));
        assert!(param_si(&flat, "nobody", "C").is_err());
    }

    #[test]
    fn set_then_read_round_trips_and_keeps_init_entries_in_init() {
        let mut flat = meter_out();
        set_param_si(&mut flat, "friction", "k0", 17.5).unwrap();
        assert_eq!(param_si(&flat, "friction", "k0").unwrap(), 17.5);
        // an initial state written in `init` (the shipped model writes none)
        component_mut(&mut flat, "rod").unwrap().init.insert("p0".into(), Value::Number(4e5));
        set_param_si(&mut flat, "rod", "p0", 7e5).unwrap();
        let rod = component(&flat, "rod").unwrap();
        assert!(rod.init.contains_key("p0") && !rod.params.contains_key("p0"));
        assert!(graph::build(&flat).is_ok());
    }

    #[test]
    fn finds_the_roles_of_the_meter_out_circuit() {
        let flat = meter_out();
        let t = Topology::of(&flat);
        assert_eq!(t.head.as_deref(), Some("head"));
        assert_eq!(t.rod.as_deref(), Some("rod"));
        assert_eq!(t.piston.as_deref(), Some("piston"));
        assert_eq!(t.valve.as_deref(), Some("dcv"));
        assert_eq!(t.friction.as_deref(), Some("friction"));
        assert_eq!(t.supply.as_deref(), Some("supply"));
        assert_eq!(t.throttles, vec!["flow_control".to_string()]);
        assert_eq!(t.command.as_deref(), Some("controller.command"));
        let node = node_of(&flat, "dcv.EA");
        assert!(node.contains(&"exhaust.port".to_string()) && node.contains(&"dcv.EB".to_string()));
    }

    #[test]
    fn fresh_ids_do_not_collide() {
        let mut flat = meter_out();
        assert_eq!(fresh_id(&flat, "leak"), "leak");
        add_component(&mut flat, "leak", "conductance", &[("C", 1e-9), ("b", 0.5)], &[]);
        assert_eq!(fresh_id(&flat, "leak"), "leak_2");
        assert_eq!(fresh_id(&flat, "head"), "head_2");
    }

    #[test]
    fn bounds_parse_with_units_outside_the_block_range() {
        let flat = meter_out();
        let v = parse_for(&flat, "flow_control", "C", &Value::Text("0 L/min/bar".into())).unwrap();
        assert_eq!(v, 0.0);
        assert!(parse_for(&flat, "flow_control", "C", &Value::Text("4 bar".into())).is_err());
    }
}
