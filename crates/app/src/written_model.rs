//! The model a discrepancy analysis hands back (`model_with_<effect>.json`,
//! `model_calibrated.json`), written as the user's own netlist with the
//! analysis's edits applied: the same `parameters` block, expressions, units,
//! sub-circuit references and built-in components, plus what changed —
//! components and connections an effect added (or rewired), and parameters
//! the fit moved, written with units ("0.42 mm", "4.9 s").
//!
//! How: the user's netlist is flattened again and compared with the
//! analysed (flat) model; each difference is written where the user would
//! write it — a top-level component's value in place; a value that was a
//! bare reference to a top-level parameter (`"= tau_thermal"`) into that
//! parameter when every use of it moved to the same value; a value inside a
//! sub-circuit into the instance's parameter that drives it. The result is
//! then flattened and checked against the analysed model (same components,
//! connections, gas and every value within 1e-6 relative); when an edit
//! cannot be expressed in the user's file (a connection to a port a
//! sub-circuit does not expose, a value the instance cannot set) this
//! returns an error and the caller writes the flat netlist instead.
//!
//! Subsystem files named by a relative path are written as absolute paths,
//! since the written file does not lie beside the model.

use crate::load::Source;
use graph::netlist::{Component, Connection, ParameterDecl, Value};
use graph::FlatNetlist;
use std::collections::BTreeMap;
use std::path::Path;

/// Relative tolerance between a written value and the analysed one (values
/// are written with 9 significant digits).
const MATCH_RTOL: f64 = 1e-6;

/// The netlist of `source` (the user's files) turned into `augmented` (that
/// netlist flattened, calibrated and edited), as JSON text with this
/// description; an error says which edit the user's file cannot express.
pub fn user_netlist_json(source: &Source, augmented: &FlatNetlist, description: &str) -> Result<String, String> {
    let text = source.files.iter().find(|(p, _)| p == &source.path).map(|(_, t)| t.as_str()).ok_or("the model's text is not held")?;
    let mut netlist = graph::expand::parse(text, &source.path.display().to_string()).map_err(|e| e.to_string())?;
    let original = source.load().map_err(|e| e.to_string())?;
    if original.gas != augmented.gas {
        netlist.gas = augmented.gas.clone();
    }
    if original.simulation != augmented.simulation {
        netlist.simulation = augmented.simulation.clone();
    }
    apply_value_changes(&mut netlist, &original, augmented)?;
    add_components(&mut netlist, &original, augmented)?;
    rewire(&mut netlist, &original, augmented)?;
    let dir = source.path.parent().unwrap_or(Path::new(""));
    absolute_subsystem_files(&mut netlist, dir);
    netlist.description = Some(match netlist.description.as_deref() {
        Some(d) if !d.trim().is_empty() => format!("{description} The model as written: {d}"),
        _ => description.to_string(),
    });
    let json = serde_json::to_string_pretty(&netlist).map_err(|e| e.to_string())? + "\n";
    let (written, _) = Source::from_text(&json, &source.path).map_err(|e| format!("the written netlist does not load: {e}"))?;
    same_model(&written, augmented)?;
    Ok(json)
}

/// A value changed by the analysis: component `id`, `key` in `params` (or `init`).
struct Change {
    id: String,
    key: String,
    init: bool,
    kind: String,
    before: Option<Value>,
    after: Value,
}

fn changes(original: &FlatNetlist, augmented: &FlatNetlist) -> Result<Vec<Change>, String> {
    let mut out = Vec::new();
    for o in &original.components {
        let Some(a) = augmented.component(&o.id) else {
            return Err(format!("component {} was removed", o.id));
        };
        for (init, before, after) in [(false, &o.params, &a.params), (true, &o.init, &a.init)] {
            if let Some(k) = before.keys().find(|k| !after.contains_key(*k)) {
                return Err(format!("{}.{k} was removed", o.id));
            }
            for (k, v) in after {
                if before.get(k) != Some(v) {
                    let (id, key, kind) = (o.id.clone(), k.clone(), o.kind.clone());
                    out.push(Change { id, key, init, kind, before: before.get(k).cloned(), after: v.clone() });
                }
            }
        }
    }
    Ok(out)
}

/// "= name" → "name", for a bare reference.
fn bare_reference(v: &Value) -> Option<&str> {
    let Value::Text(t) = v else { return None };
    let name = t.trim().strip_prefix('=')?.trim();
    graph::params::valid_parameter_name(name).then_some(name)
}

/// Whether `name` appears as a word in `text`.
fn mentions(text: &str, name: &str) -> bool {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.')).any(|w| w == name)
}

fn value_mentions(v: &Value, name: &str) -> bool {
    match v {
        Value::Text(t) => units::expr::is_expression(t) && mentions(t, name),
        Value::List(xs) => xs.iter().any(|x| value_mentions(x, name)),
        Value::Number(_) => false,
    }
}

/// The unit a literal was written in ("13.2 L/min/bar" → "L/min/bar").
fn literal_unit(v: &Value) -> Option<String> {
    let Value::Text(t) = v else { return None };
    if units::expr::is_expression(t) {
        return None;
    }
    let (number, unit) = t.trim().split_once(char::is_whitespace)?;
    (number.parse::<f64>().is_ok() && !unit.trim().is_empty()).then(|| unit.trim().to_string())
}

/// An SI number written in `unit` with 9 significant digits ("0.42 mm");
/// a plain number when the unit is empty or does not convert.
fn with_unit(si: f64, unit: &str) -> Value {
    match units::to_unit(si, unit) {
        Ok(x) if !unit.is_empty() && x.is_finite() => Value::Text(format!("{} {unit}", short(x))),
        _ => Value::Number(si),
    }
}

/// A number rounded to 9 significant digits, printed shortest.
fn short(x: f64) -> String {
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    format!("{rounded}")
}

/// The value to write for a change: numbers in the unit the user wrote
/// (or the block's display unit), anything else as it stands.
fn written_value(c: &Change) -> Value {
    let Value::Number(si) = c.after else { return c.after.clone() };
    let unit = c.before.as_ref().and_then(literal_unit).or_else(|| display_unit(&c.kind, &c.key)).unwrap_or_default();
    with_unit(si, &unit)
}

fn display_unit(kind: &str, param: &str) -> Option<String> {
    let ty = blocks::registry::block_type(kind).ok()?;
    ty.params.iter().find(|s| s.name == param).map(|s| s.display_unit.to_string())
}

fn apply_value_changes(netlist: &mut graph::Netlist, original: &FlatNetlist, augmented: &FlatNetlist) -> Result<(), String> {
    let changes = changes(original, augmented)?;
    // top-level parameters all of whose uses moved to one value are set in
    // the parameters block (the block keeps driving the model)
    let mut by_parameter: BTreeMap<String, Vec<&Change>> = BTreeMap::new();
    for c in changes.iter().filter(|c| !c.id.contains('.')) {
        if let Some(name) = c.before.as_ref().and_then(bare_reference) {
            if netlist.parameters.contains_key(name) {
                by_parameter.entry(name.to_string()).or_default().push(c);
            }
        }
    }
    let mut via_parameter: Vec<(&str, &str)> = Vec::new();
    for (name, group) in &by_parameter {
        let same = group.iter().all(|c| c.after == group[0].after);
        let covered = |id: &str, key: &str| group.iter().any(|c| c.id == id && c.key == key);
        let other_use = netlist
            .components
            .iter()
            .any(|comp| comp.params.iter().chain(comp.init.iter()).any(|(k, v)| value_mentions(v, name) && !covered(&comp.id, k)))
            || netlist.parameters.iter().any(|(n, d)| n != name && value_mentions(d.value(), name));
        let Value::Number(si) = group[0].after else { continue };
        if !same || other_use {
            continue;
        }
        let unit = original.parameter(name).map(|p| p.declared_unit.clone()).filter(|u| !u.is_empty());
        let unit = unit.or_else(|| display_unit(&group[0].kind, &group[0].key)).unwrap_or_default();
        if let Some(decl) = netlist.parameters.get_mut(name.as_str()) {
            let value = with_unit(si, &unit);
            *decl = match decl {
                ParameterDecl::Full { description, .. } => ParameterDecl::Full { value, description: description.clone() },
                ParameterDecl::Short(_) => ParameterDecl::Short(value),
            };
        }
        via_parameter.extend(group.iter().map(|c| (c.id.as_str(), c.key.as_str())));
    }
    for c in &changes {
        if via_parameter.contains(&(c.id.as_str(), c.key.as_str())) {
            continue;
        }
        let value = written_value(c);
        match c.id.split_once('.') {
            None => {
                let comp = netlist.components.iter_mut().find(|x| x.id == c.id).ok_or_else(|| format!("no component {}", c.id))?;
                let map = if c.init { &mut comp.init } else { &mut comp.params };
                map.insert(c.key.clone(), value);
            }
            Some((instance, inner)) => set_through_instance(netlist, original, c, instance, inner, value)?,
        }
    }
    Ok(())
}

/// A value inside sub-circuit `instance`: set the instance parameter that
/// drives it (a bare reference to one of its parameters, or an interface
/// parameter aimed at it). Whether every other value that parameter drives
/// moved with it is checked on the whole result.
fn set_through_instance(
    netlist: &mut graph::Netlist,
    original: &FlatNetlist,
    c: &Change,
    instance: &str,
    inner: &str,
    value: Value,
) -> Result<(), String> {
    let target = format!("{}.{}", c.id, c.key);
    let scope_ok = original.component(&c.id).is_some_and(|o| o.scope_of(&c.key) == instance) && !inner.contains('.');
    let by_reference = c.before.as_ref().and_then(bare_reference).filter(|_| scope_ok).map(str::to_string);
    let by_alias = || {
        original
            .aliases
            .iter()
            .find(|(_, ts)| ts.contains(&target))
            .and_then(|(a, _)| a.strip_prefix(&format!("{instance}.")))
            .map(str::to_string)
    };
    let name = by_reference.or_else(by_alias).ok_or_else(|| format!("{target} cannot be set from the sub-circuit's instance"))?;
    let comp = netlist.components.iter_mut().find(|x| x.id == instance).ok_or_else(|| format!("no instance {instance}"))?;
    comp.params.insert(name, value);
    Ok(())
}

fn add_components(netlist: &mut graph::Netlist, original: &FlatNetlist, augmented: &FlatNetlist) -> Result<(), String> {
    for a in augmented.components.iter().filter(|a| original.component(&a.id).is_none()) {
        if a.id.contains('.') {
            return Err(format!("component {} was added inside a sub-circuit", a.id));
        }
        let write = |m: &BTreeMap<String, Value>| -> BTreeMap<String, Value> {
            m.iter()
                .map(|(k, v)| {
                    let v = match v {
                        Value::Number(si) => with_unit(*si, &display_unit(&a.kind, k).unwrap_or_default()),
                        other => other.clone(),
                    };
                    (k.clone(), v)
                })
                .collect()
        };
        netlist.components.push(Component {
            id: a.id.clone(),
            kind: a.kind.clone(),
            file: None,
            params: write(&a.params),
            init: write(&a.init),
            origin: String::new(),
            scopes: BTreeMap::new(),
        });
    }
    Ok(())
}

/// (a, b) in a fixed order, for comparing connections regardless of direction.
fn unordered(a: &str, b: &str) -> (String, String) {
    if a <= b {
        (a.to_string(), b.to_string())
    } else {
        (b.to_string(), a.to_string())
    }
}

/// Connections are multisets: what `augmented` lacks is removed from the
/// user's list (matched by its written ends), what it adds is appended.
fn rewire(netlist: &mut graph::Netlist, original: &FlatNetlist, augmented: &FlatNetlist) -> Result<(), String> {
    let mut remaining: Vec<(String, String)> = augmented.connections.iter().map(|(a, b)| unordered(a, b)).collect();
    let mut removed = Vec::new();
    for (a, b) in &original.connections {
        let key = unordered(a, b);
        match remaining.iter().position(|x| *x == key) {
            Some(i) => {
                remaining.remove(i);
            }
            None => removed.push((a.clone(), b.clone())),
        }
    }
    let top_level = |port: &str| graph::netlist::split_ref(port).is_some_and(|(id, _)| !id.contains('.'));
    for (a, b) in &removed {
        let key = unordered(a, b);
        let i = netlist
            .connections
            .iter()
            .position(|c| {
                let (x, y) = c.ends();
                unordered(x, y) == key
            })
            .ok_or_else(|| format!("the connection {a} – {b} is not written in the model's file"))?;
        netlist.connections.remove(i);
    }
    // what augmented adds, in its own order and direction
    let mut added: Vec<(String, String)> = Vec::new();
    let mut pool: Vec<(String, String)> =
        original.connections.iter().filter(|c| !removed.contains(c)).map(|(a, b)| unordered(a, b)).collect();
    for (a, b) in &augmented.connections {
        match pool.iter().position(|x| *x == unordered(a, b)) {
            Some(i) => {
                pool.remove(i);
            }
            None => added.push((a.clone(), b.clone())),
        }
    }
    for (a, b) in added {
        if !(top_level(&a) && top_level(&b)) {
            return Err(format!("the connection {a} – {b} reaches inside a sub-circuit"));
        }
        let signal = graph::netlist::split_ref(&a).is_some_and(|(id, port)| is_signal_port(augmented, id, port));
        netlist.connections.push(if signal { Connection::Object { from: a, to: b } } else { Connection::Pair([a, b]) });
    }
    Ok(())
}

fn is_signal_port(flat: &FlatNetlist, id: &str, port: &str) -> bool {
    let Some(c) = flat.component(id) else { return false };
    blocks::registry::block_type(&c.kind)
        .is_ok_and(|t| t.ports.iter().any(|s| s.name == port && s.kind.domain() == blocks::block::Domain::Signal))
}

fn absolute_subsystem_files(netlist: &mut graph::Netlist, dir: &Path) {
    for c in netlist.components.iter_mut() {
        if let Some(file) = &c.file {
            if graph::library::from_file(file).is_none() && Path::new(file).is_relative() {
                let full = dir.join(file);
                let full = std::fs::canonicalize(&full).unwrap_or(full);
                c.file = Some(full.display().to_string());
            }
        }
    }
}

/// Whether two flat netlists are the same model: components and their
/// types, every value (SI, within [`MATCH_RTOL`]), connections, gas and
/// simulation settings.
fn same_model(written: &FlatNetlist, augmented: &FlatNetlist) -> Result<(), String> {
    if written.gas != augmented.gas {
        return Err("the gas model differs".into());
    }
    if written.simulation != augmented.simulation {
        return Err("the simulation settings differ".into());
    }
    let mut cw: Vec<(String, String)> = written.connections.iter().map(|(a, b)| unordered(a, b)).collect();
    let mut ca: Vec<(String, String)> = augmented.connections.iter().map(|(a, b)| unordered(a, b)).collect();
    cw.sort();
    ca.sort();
    if cw != ca {
        return Err("the connections differ".into());
    }
    let rw = graph::resolve(written).map_err(|e| e.to_string())?;
    let ra = graph::resolve(augmented).map_err(|e| e.to_string())?;
    if written.components.len() != augmented.components.len() {
        return Err("the components differ".into());
    }
    for a in &augmented.components {
        let w = written.component(&a.id).filter(|w| w.kind == a.kind).ok_or_else(|| format!("component {} differs", a.id))?;
        let keys: Vec<&String> = a.params.keys().chain(a.init.keys()).chain(w.params.keys()).chain(w.init.keys()).collect();
        for k in keys {
            let full = format!("{}.{k}", a.id);
            let same = match (rw.get(&full), ra.get(&full)) {
                (Some(x), Some(y)) => (x.si - y.si).abs() <= MATCH_RTOL * y.si.abs().max(f64::MIN_POSITIVE),
                _ => a.value(k) == w.value(k),
            };
            if !same {
                return Err(format!("{full} differs"));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use identify::effects::Effect;
    use identify::netlist_edit::set_param_si;

    fn meter_out() -> (FlatNetlist, Source) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/meter_out.json");
        Source::read(&path).expect("models/meter_out.json")
    }

    /// The shipped model calibrated (a throttle, friction, both chambers'
    /// time constant) and given a seal leak and a valve delay, as the
    /// workflow hands it back.
    fn analysed(base: &FlatNetlist) -> FlatNetlist {
        let mut flat = base.clone();
        set_param_si(&mut flat, "flow_control", "C", 12.7e-3 / 60.0 / 1e5).unwrap();
        set_param_si(&mut flat, "friction", "k0", 13.25).unwrap();
        set_param_si(&mut flat, "head", "tau_thermal", 4.9).unwrap();
        set_param_si(&mut flat, "rod", "tau_thermal", 4.9).unwrap();
        identify::effects::PistonSealLeak.apply(&mut flat, &[0.3e-3 / 60.0 / 1e5, 0.0]).unwrap();
        identify::effects::ValveDelay.apply(&mut flat, &[0.02]).unwrap();
        flat
    }

    fn warnings(flat: &FlatNetlist) -> Vec<String> {
        let mut w = Vec::new();
        crate::check::check(flat, &mut |ws| w.extend(ws.iter().map(|x| x.to_string()))).expect("check");
        w
    }

    /// The analysed and the written model simulate alike for 1.5 s, and the piston moves.
    fn same_run(augmented: &FlatNetlist, written: &FlatNetlist) {
        let s = identify::problem::SimSettings::default();
        let run = |f: &FlatNetlist| identify::problem::simulate_netlist(f, 1.5, 2e-3, &s).expect("simulate");
        let (a, b) = (run(augmented), run(written));
        for (col, tol) in [("piston.x", 1e-6), ("head.p", 1.0), ("rod.T", 1e-3)] {
            let (ya, yb) = (a.series(col).unwrap(), b.series(col).unwrap());
            assert_eq!(ya.len(), yb.len());
            let worst = ya.iter().zip(&yb).map(|(p, q)| (p.1 - q.1).abs()).fold(0.0, f64::max);
            assert!(worst < tol, "{col}: {worst}");
        }
        let x_end = a.series("piston.x").unwrap().last().unwrap().1;
        assert!(x_end > 0.05, "the run moves the piston: {x_end}");
    }

    #[test]
    fn a_user_declared_effect_is_written_like_a_built_in() {
        let (base, source) = meter_out();
        let spec: identify::effects::user::UserEffectSpec = serde_json::from_str(
            r#"{ "name": "seal_bypass", "components": [ { "id": "bypass", "type": "conductance", "params": { "b": 0.5 } } ],
                 "connections": [ ["head.port", "bypass.a"], ["bypass.b", "rod.port"] ],
                 "free": { "bypass.C": { "null": "0 L/min/bar", "start": "0.2 L/min/bar", "bounds": ["0 L/min/bar", "5 L/min/bar"] } } }"#,
        )
        .unwrap();
        let effect = identify::effects::UserEffect::declare(&spec, &base).unwrap();
        let mut augmented = base.clone();
        set_param_si(&mut augmented, "friction", "k0", 13.25).unwrap();
        effect.apply(&mut augmented, &[2.0e-3 / 60.0 / 1e5]).unwrap();
        let json = user_netlist_json(&source, &augmented, "test.").expect("expressible");
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let bypass = v["components"].as_array().unwrap().iter().find(|c| c["id"] == "bypass").unwrap().clone();
        assert_eq!((bypass["type"].as_str(), &bypass["params"]["b"]), (Some("conductance"), &serde_json::json!(0.5)));
        assert_eq!(bypass["params"]["C"], "2 L/min/bar");
        let conns = v["connections"].to_string();
        assert!(conns.contains(r#"["head.port","bypass.a"]"#) && conns.contains(r#"["bypass.b","rod.port"]"#), "{conns}");
        let (written, _) = Source::from_text(&json, &source.path).unwrap();
        assert_eq!(warnings(&written), Vec::<String>::new());
        same_run(&augmented, &written);
    }

    #[test]
    fn the_users_netlist_is_kept_with_the_edits_written_in_units() {
        let (base, source) = meter_out();
        let augmented = analysed(&base);
        let json = user_netlist_json(&source, &augmented, "test.").expect("expressible");
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        // the parameters block stays, the shared time constant moved into it
        assert_eq!(v["parameters"]["bore"]["value"], "45 mm");
        assert_eq!(v["parameters"]["tau_thermal"]["value"], "4.9 s");
        let comp = |id: &str| v["components"].as_array().unwrap().iter().find(|c| c["id"] == id).unwrap().clone();
        assert_eq!(comp("head")["params"]["tau_thermal"], "= tau_thermal");
        assert_eq!(comp("head")["params"]["bore"], "= bore");
        assert_eq!(comp("flow_control")["params"]["C"], "12.7 L/min/bar");
        assert_eq!(comp("friction")["params"]["k0"], "13.25 N");
        assert_eq!(comp("valve_delay")["params"]["delay"], "20 ms");
        assert!(v["interface"]["outputs"]["x"].is_object(), "the interface is kept");
        // it loads without a warning (the flat writer gave many) and is the same model
        let (written, _) = Source::from_text(&json, &source.path).unwrap();
        assert_eq!(warnings(&written), Vec::<String>::new());
        let flat_text = crate::discrepancy::netlist_json(&augmented, "flat".into()).unwrap();
        let (flat_written, _) = Source::from_text(&flat_text, &source.path).unwrap();
        assert!(warnings(&flat_written).len() >= 10, "the flat writer's warnings are what this replaces");
        same_run(&augmented, &written);
        // the parameters block still drives the model
        let changed = json.replacen("\"45 mm\"", "\"50 mm\"", 1);
        let (bigger, _) = Source::from_text(&changed, &source.path).unwrap();
        let r = graph::resolve(&bigger).unwrap();
        assert!((r.get("head.bore").unwrap().si - 0.05).abs() < 1e-12 && (r.get("rod.bore").unwrap().si - 0.05).abs() < 1e-12);
    }

    #[test]
    fn a_value_used_apart_from_its_parameter_is_written_in_place() {
        let (base, source) = meter_out();
        let mut augmented = base.clone();
        // only the head's time constant moves: the parameter keeps driving the rod
        set_param_si(&mut augmented, "head", "tau_thermal", 3.5).unwrap();
        let json = user_netlist_json(&source, &augmented, "test.").unwrap();
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(v["parameters"]["tau_thermal"]["value"], "5 s");
        let comp = |id: &str| v["components"].as_array().unwrap().iter().find(|c| c["id"] == id).unwrap().clone();
        assert_eq!(comp("head")["params"]["tau_thermal"], "3.5 s");
        assert_eq!(comp("rod")["params"]["tau_thermal"], "= tau_thermal");
        // an edit inside a sub-circuit the instance cannot express is refused (the caller writes flat)
        let mut inner = base.clone();
        for c in inner.components.iter_mut() {
            c.id = format!("sub.{}", c.id);
        }
        assert!(user_netlist_json(&source, &inner, "x").is_err());
    }
}
