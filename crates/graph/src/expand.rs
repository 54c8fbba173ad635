//! Reading netlists, applying `--set` overrides and expanding subsystems into
//! one flat list of components and connections.
//!
//! Files are reached through the [`Loader`] trait so that this crate never
//! touches the file system itself (the CLI provides the real loader, tests an
//! in-memory one). Inner ids of a subsystem `cyl` become `cyl.head`,
//! `cyl.piston`, ...; its exposed ports `cyl.head_port` are rewritten to the
//! inner ports they stand for.

use crate::netlist::{split_ref, Component, GasModelName, Netlist, Simulation, Species, Value};
use crate::GraphError;
use std::collections::BTreeMap;
use std::path::Path;

/// Source of netlist text.
pub trait Loader {
    /// Read the file at `path` (already resolved against the including netlist).
    fn read(&self, path: &Path) -> Result<String, String>;
}

/// A circuit with subsystems expanded.
#[derive(Debug, Clone, PartialEq)]
pub struct FlatNetlist {
    pub name: String,
    pub gas: crate::netlist::GasChoice,
    pub components: Vec<Component>,
    /// (from, to) port references.
    pub connections: Vec<(String, String)>,
    pub simulation: Simulation,
}

/// Parse netlist text; errors carry the file, line and column.
pub fn parse(text: &str, origin: &str) -> Result<Netlist, GraphError> {
    serde_json::from_str(text).map_err(|e| GraphError::Json {
        file: origin.to_string(),
        line: e.line(),
        column: e.column(),
        message: e.to_string().split(" at line ").next().unwrap_or_default().to_string(),
    })
}

/// Load, parse and expand the netlist at `path`.
pub fn load(loader: &dyn Loader, path: &Path) -> Result<FlatNetlist, GraphError> {
    let text = loader.read(path).map_err(|message| GraphError::Io { file: path.display().to_string(), message })?;
    let netlist = parse(&text, &path.display().to_string())?;
    flatten(loader, &netlist, path.parent().unwrap_or(Path::new("")), 0)
}

/// Expand a parsed netlist whose subsystem files are relative to `dir`.
pub fn flatten(loader: &dyn Loader, netlist: &Netlist, dir: &Path, depth: usize) -> Result<FlatNetlist, GraphError> {
    if depth > 16 {
        return Err(GraphError::Subsystem {
            id: netlist.name.clone().unwrap_or_default(),
            message: "subsystems nested more than 16 deep (a file including itself?)".into(),
        });
    }
    let mut components = Vec::new();
    let mut connections = Vec::new();
    // exposed "sub.port" → inner "sub.inner.port"
    let mut exposed: BTreeMap<String, String> = BTreeMap::new();
    for c in &netlist.components {
        if c.kind != "subsystem" {
            components.push(c.clone());
            continue;
        }
        let file =
            c.file.as_deref().ok_or_else(|| GraphError::Subsystem { id: c.id.clone(), message: "a subsystem needs \"file\"".into() })?;
        let path = dir.join(file);
        let text = loader.read(&path).map_err(|message| GraphError::Io { file: path.display().to_string(), message })?;
        let sub = parse(&text, &path.display().to_string())?;
        let mut inner = flatten(loader, &sub, path.parent().unwrap_or(Path::new("")), depth + 1)?;
        let interface = sub.interface.clone().unwrap_or_default();
        // parameters set through the interface
        for (name, value) in c.params.iter().chain(c.init.iter()) {
            let targets = interface.params.get(name).ok_or_else(|| GraphError::Subsystem {
                id: c.id.clone(),
                message: format!(
                    "unknown parameter \"{name}\" (the subsystem exposes: {})",
                    interface.params.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            })?;
            for target in targets {
                let (tid, tparam) = split_ref(target)
                    .ok_or_else(|| GraphError::Subsystem { id: c.id.clone(), message: format!("bad interface target \"{target}\"") })?;
                let comp = inner.components.iter_mut().find(|ic| ic.id == tid).ok_or_else(|| GraphError::Subsystem {
                    id: c.id.clone(),
                    message: format!("interface parameter \"{name}\" points to unknown component \"{tid}\""),
                })?;
                comp.init.remove(tparam);
                comp.params.insert(tparam.to_string(), value.clone());
            }
        }
        for ic in inner.components {
            components.push(Component { id: format!("{}.{}", c.id, ic.id), ..ic });
        }
        for (a, b) in inner.connections {
            connections.push((format!("{}.{a}", c.id), format!("{}.{b}", c.id)));
        }
        for (name, target) in &interface.ports {
            exposed.insert(format!("{}.{name}", c.id), format!("{}.{target}", c.id));
        }
    }
    for conn in &netlist.connections {
        let (a, b) = conn.ends();
        let map = |r: &str| exposed.get(r).cloned().unwrap_or_else(|| r.to_string());
        connections.push((map(a), map(b)));
    }
    Ok(FlatNetlist {
        name: netlist.name.clone().unwrap_or_else(|| "circuit".into()),
        gas: netlist.gas.clone(),
        components,
        connections,
        simulation: netlist.simulation.clone(),
    })
}

/// Read a `--set` value: a plain number is SI, anything else keeps its text (with unit).
pub fn value_from_text(text: &str) -> Value {
    match text.trim().parse::<f64>() {
        Ok(x) => Value::Number(x),
        Err(_) => Value::Text(text.trim().to_string()),
    }
}

/// Apply an override "ID.PARAM=VALUE" to the flat netlist.
pub fn apply_set(flat: &mut FlatNetlist, assignment: &str) -> Result<(), GraphError> {
    let bad = |message: &str| GraphError::Set { assignment: assignment.to_string(), message: message.to_string() };
    let (target, value) = assignment.split_once('=').ok_or_else(|| bad("expected ID.PARAM=VALUE"))?;
    let (id, param) = split_ref(target.trim()).ok_or_else(|| bad("expected ID.PARAM=VALUE"))?;
    if id == "simulation" {
        return apply_simulation_set(&mut flat.simulation, param, value).map_err(|m| bad(&m));
    }
    if let Some(words) = gas_setting_words(flat, id, param) {
        return apply_gas_set(&mut flat.gas, param, value, words.map_err(|m| bad(&m))?).map_err(|m| bad(&m));
    }
    let comp = flat.components.iter_mut().find(|c| c.id == id).ok_or_else(|| bad(&format!("no component \"{id}\"")))?;
    comp.init.remove(param);
    comp.params.insert(param.to_string(), value_from_text(value));
    Ok(())
}

/// When `id.param` names the circuit's gas (`gas.model`, `gas.species`; a
/// component called "gas" takes precedence): the words it accepts, or why the
/// setting is unknown. `None` when `id.param` is not about the gas.
pub fn gas_setting_words(flat: &FlatNetlist, id: &str, param: &str) -> Option<Result<&'static [&'static str], String>> {
    if id != "gas" || flat.components.iter().any(|c| c.id == "gas") {
        return None;
    }
    Some(match param {
        "model" => Ok(GasModelName::NAMES),
        "species" => Ok(Species::NAMES),
        _ => Err(format!("unknown gas setting \"{param}\" (model, species)")),
    })
}

/// Set `gas.<param>` to the listed word `value` names (case-insensitive).
fn apply_gas_set(gas: &mut crate::netlist::GasChoice, param: &str, value: &str, words: &[&str]) -> Result<(), String> {
    let value = value.trim();
    let unknown = || format!("unknown gas {param} \"{value}\" ({})", words.join(", "));
    let word = words.iter().find(|w| w.eq_ignore_ascii_case(value)).ok_or_else(unknown)?;
    let word = serde_json::Value::String(word.to_string());
    if param == "model" {
        gas.model = serde_json::from_value(word).map_err(|_| unknown())?;
    } else {
        gas.species = serde_json::from_value(word).map_err(|_| unknown())?;
    }
    Ok(())
}

fn apply_simulation_set(sim: &mut Simulation, param: &str, value: &str) -> Result<(), String> {
    let num = || value.trim().parse::<f64>().map_err(|_| format!("\"{value}\" is not a number"));
    match param {
        "rtol" => sim.rtol = num()?,
        "atol" => sim.atol = num()?,
        "t_end" => sim.t_end = Some(value_from_text(value)),
        "sample_interval" => sim.sample_interval = Some(value_from_text(value)),
        "max_step" => sim.max_step = Some(value_from_text(value)),
        "cycles" => sim.cycles = Some(value.trim().parse().map_err(|_| format!("\"{value}\" is not a whole number"))?),
        _ => return Err(format!("unknown simulation setting \"{param}\" (rtol, atol, t_end, cycles, sample_interval, max_step)")),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoFiles;
    impl Loader for NoFiles {
        fn read(&self, path: &Path) -> Result<String, String> {
            Err(format!("no file {}", path.display()))
        }
    }

    fn flat(components: &str) -> FlatNetlist {
        let text = format!(r#"{{"name": "t", "components": [{components}]}}"#);
        flatten(&NoFiles, &parse(&text, "t.json").unwrap(), Path::new("."), 0).unwrap()
    }

    #[test]
    fn gas_model_and_species_are_set_by_name() {
        let mut f = flat(r#"{"id": "v", "type": "chamber", "params": {}}"#);
        assert_eq!(f.gas.model, GasModelName::Ideal);
        apply_set(&mut f, "gas.model=real").unwrap();
        apply_set(&mut f, "gas.species= nitrogen").unwrap();
        assert_eq!((f.gas.model, f.gas.species), (GasModelName::Real, Species::Nitrogen));
        apply_set(&mut f, "gas.model=Semi_Perfect").unwrap();
        assert_eq!(f.gas.model, GasModelName::SemiPerfect);
    }

    #[test]
    fn every_listed_gas_word_is_accepted() {
        let mut f = flat(r#"{"id": "v", "type": "chamber", "params": {}}"#);
        for word in GasModelName::NAMES {
            apply_set(&mut f, &format!("gas.model={word}")).unwrap();
        }
        for word in Species::NAMES {
            apply_set(&mut f, &format!("gas.species={word}")).unwrap();
        }
    }

    #[test]
    fn unknown_gas_settings_name_the_choices() {
        let mut f = flat(r#"{"id": "v", "type": "chamber", "params": {}}"#);
        let e = apply_set(&mut f, "gas.model=van_der_waals").unwrap_err().to_string();
        assert!(e.contains("van_der_waals") && e.contains("ideal, semi_perfect, real"), "{e}");
        let e = apply_set(&mut f, "gas.pressure=3").unwrap_err().to_string();
        assert!(e.contains("\"pressure\"") && e.contains("model, species"), "{e}");
        assert_eq!(f.gas.model, GasModelName::Ideal);
    }

    #[test]
    fn a_component_called_gas_keeps_its_parameters() {
        let mut f = flat(r#"{"id": "gas", "type": "chamber", "params": {}}"#);
        apply_set(&mut f, "gas.model=real").unwrap();
        assert_eq!(f.gas.model, GasModelName::Ideal);
        assert!(f.components[0].params.contains_key("model"));
    }
}
