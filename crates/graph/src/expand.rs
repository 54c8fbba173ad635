//! Reading netlists, applying `--set` overrides and expanding subsystems into
//! one flat list of components and connections.
//!
//! Files are reached through the [`Loader`] trait so that this crate never
//! touches the file system itself (the CLI provides the real loader, tests an
//! in-memory one). Inner ids of a subsystem `cyl` become `cyl.head`,
//! `cyl.piston`, ...; its exposed ports `cyl.head_port` are rewritten to the
//! inner ports they stand for.

use crate::netlist::{split_ref, Component, GasModelName, InitialMode, MethodName, Netlist, Simulation, Species, Value};
use crate::GraphError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Source of netlist text.
pub trait Loader {
    /// Read the file at `path` (already resolved against the including netlist).
    fn read(&self, path: &Path) -> Result<String, String>;
    /// Most components a circuit may expand to (subsystems included); a
    /// netlist that expands further is refused while it is expanded.
    fn max_components(&self) -> usize {
        DEFAULT_MAX_COMPONENTS
    }
}

/// Default of [`Loader::max_components`].
pub const DEFAULT_MAX_COMPONENTS: usize = 100_000;

/// A named parameter after expansion: top-level (`bore`) or of a subsystem
/// instance (`cyl.bore`).
#[derive(Debug, Clone, PartialEq)]
pub struct FlatParameter {
    /// Full name (`bore`, `cyl.bore`).
    pub name: String,
    /// Number, text with unit, or expression.
    pub value: Value,
    pub description: Option<String>,
    /// Scope in which the names of an expression value are looked up
    /// ("" = top level, "cyl" = inside instance `cyl`).
    pub scope: String,
    /// File that declared it.
    pub origin: String,
    /// Dimension and unit of the value the file gave it, when that is a
    /// literal ("45 mm"): a plain-number override keeps this dimension.
    pub declared_dim: Option<units::Dimension>,
    pub declared_unit: String,
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
    /// Named parameters (top level and of every subsystem instance).
    pub parameters: Vec<FlatParameter>,
    /// Interface parameters of subsystem instances: `cyl.T0` → the inner
    /// `id.param` it sets (`cyl.head.T0`, `cyl.rod.T0`).
    pub aliases: BTreeMap<String, Vec<String>>,
    /// File of the top-level netlist.
    pub origin: String,
    /// The top-level netlist's model inputs, in the order it writes them (an included subsystem's are not kept).
    pub inputs: crate::netlist::OrderedMap<crate::netlist::InputDecl>,
    /// The top-level netlist's model outputs, in the order it writes them.
    pub outputs: crate::netlist::OrderedMap<crate::netlist::OutputDecl>,
}

impl FlatNetlist {
    pub fn parameter(&self, name: &str) -> Option<&FlatParameter> {
        self.parameters.iter().find(|p| p.name == name)
    }
    pub fn component(&self, id: &str) -> Option<&Component> {
        self.components.iter().find(|c| c.id == id)
    }
}

/// Deepest nesting of subsystems.
pub const MAX_NESTING: usize = 16;

/// Parse netlist text; errors carry the file, line and column.
pub fn parse(text: &str, origin: &str) -> Result<Netlist, GraphError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    serde_json::from_str(text).map_err(|e| GraphError::Json {
        file: origin.to_string(),
        line: e.line(),
        column: e.column(),
        message: units::show::quoting(e.to_string().split(" at line ").next().unwrap_or_default()),
    })
}

/// Load, parse and expand the netlist at `path`.
pub fn load(loader: &dyn Loader, path: &Path) -> Result<FlatNetlist, GraphError> {
    let text = loader.read(path).map_err(|message| GraphError::Io { file: crate::escape(&path.display().to_string()), message })?;
    let netlist = parse(&text, &path.display().to_string())?;
    expand(loader, &netlist, path, &mut vec![path.to_path_buf()])
}

/// Expand a parsed netlist whose subsystem files are relative to `dir`.
pub fn flatten(loader: &dyn Loader, netlist: &Netlist, dir: &Path, depth: usize) -> Result<FlatNetlist, GraphError> {
    let origin = dir.join(netlist.name.as_deref().unwrap_or("netlist"));
    let mut chain = vec![PathBuf::new(); depth];
    chain.push(origin.clone());
    expand(loader, netlist, &origin, &mut chain)
}

fn valid_user_id(id: &str) -> bool {
    !id.is_empty() && id.len() <= crate::MAX_NAME_CHARS && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Where the netlist of a subsystem component comes from.
enum SubSource {
    /// A built-in sub-circuit (`"type": "cylinder"`, `"file": "lib:cylinder"`).
    BuiltIn(&'static crate::library::Entry),
    /// A file, resolved against the including netlist's folder, and as written.
    File { path: PathBuf, written: String },
}

/// The netlist a component expands to, or `None` for a block; an unknown
/// type, a missing `file` or a `file` on a block is an error naming the
/// component and the file it is written in.
fn subsystem_source(c: &Component, origin: &str, dir: &Path) -> Result<Option<SubSource>, GraphError> {
    let at = |message: String| GraphError::Component { file: origin.to_string(), id: c.id.clone(), message };
    if c.kind == "subsystem" {
        let written = c.file.as_deref().ok_or_else(|| {
            at(format!(
                "a subsystem needs \"file\" (a netlist, relative to this one, or a built-in: {})",
                crate::library::names().iter().map(|n| format!("\"{}{n}\"", crate::library::FILE_PREFIX)).collect::<Vec<_>>().join(", ")
            ))
        })?;
        return match crate::library::from_file(written) {
            Some(found) => found.map(|entry| Some(SubSource::BuiltIn(entry))).map_err(at),
            None => Ok(Some(SubSource::File { path: dir.join(written), written: written.to_string() })),
        };
    }
    let built_in = crate::library::get(&c.kind);
    if built_in.is_none() && blocks::registry::block_type(&c.kind).is_err() {
        let known = blocks::registry::TYPES.iter().map(|t| t.name).chain(crate::library::names()).chain(["subsystem"]);
        let hint = blocks::suggest::did_you_mean(&c.kind, known.clone());
        return Err(at(format!(
            "unknown component type \"{}\"{hint} (blocks: {}; built-in components: {}; or \"subsystem\" with a \"file\")",
            crate::escape(&c.kind),
            blocks::registry::TYPES.iter().map(|t| t.name).collect::<Vec<_>>().join(", "),
            crate::library::names().join(", ")
        )));
    }
    if let Some(file) = &c.file {
        return Err(at(format!(
            "\"file\": \"{}\" is only read for \"type\": \"subsystem\"; this component is a {}",
            crate::escape(file),
            c.kind
        )));
    }
    Ok(built_in.map(SubSource::BuiltIn))
}

/// A hint after a subsystem file that cannot be read, when its name is that
/// of a built-in component (`lib/cylinder.json`: `"type": "cylinder"`).
fn built_in_hint(written: &str) -> String {
    let stem = Path::new(written).file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let near = blocks::suggest::nearest(stem, crate::library::names());
    match crate::library::get(stem).map(|e| e.name).or(near.first().copied()) {
        Some(name) => format!("; the built-in {name} needs no file: write \"type\": \"{name}\""),
        None => String::new(),
    }
}

/// Refuse a file that includes itself, or nesting deeper than [`MAX_NESTING`].
fn check_chain(chain: &[PathBuf], path: &Path, id: &str) -> Result<(), GraphError> {
    if chain.len() > MAX_NESTING || chain.iter().any(|f| f == path) {
        let files: Vec<String> = chain.iter().map(|f| f.as_path()).chain([path]).map(|f| f.display().to_string()).collect();
        let why = if chain.len() > MAX_NESTING {
            format!("subsystems nested more than {MAX_NESTING} deep")
        } else {
            "a subsystem includes itself".to_string()
        };
        return Err(GraphError::Subsystem { id: id.to_string(), message: format!("{why}: {}", files.join(" -> ")) });
    }
    Ok(())
}

/// Expand `netlist`, read from `file`; `chain` lists the files including it (itself last).
fn expand(loader: &dyn Loader, netlist: &Netlist, file: &Path, chain: &mut Vec<PathBuf>) -> Result<FlatNetlist, GraphError> {
    let origin = file.display().to_string();
    let dir = file.parent().unwrap_or(Path::new(""));
    let mut components = Vec::new();
    let mut connections = Vec::new();
    let mut parameters = Vec::new();
    let mut aliases = BTreeMap::new();
    for (name, decl) in &netlist.parameters {
        if !crate::params::valid_parameter_name(name) {
            return Err(GraphError::BadParameterName { file: origin.clone(), name: name.clone() });
        }
        let (declared_dim, declared_unit) = match decl.value() {
            Value::Text(t) if !units::expr::is_expression(t) => {
                (crate::params::literal(t).ok().map(|q| q.dim), crate::params::literal_unit(t))
            }
            _ => (None, String::new()),
        };
        parameters.push(FlatParameter {
            name: name.clone(),
            value: decl.value().clone(),
            description: decl.description().map(str::to_string),
            scope: String::new(),
            origin: origin.clone(),
            declared_dim,
            declared_unit,
        });
    }
    // exposed "sub.port" → inner "sub.inner.port"
    let mut exposed: BTreeMap<String, String> = BTreeMap::new();
    for c in &netlist.components {
        if !valid_user_id(&c.id) {
            return Err(GraphError::BadId { file: origin.clone(), id: c.id.clone() });
        }
        if netlist.parameters.contains_key(&c.id) {
            return Err(GraphError::Subsystem {
                id: c.id.clone(),
                message: format!("{origin}: \"{}\" is both a component and a parameter", c.id),
            });
        }
        let Some(sub_source) = subsystem_source(c, &origin, dir)? else {
            if components.len() >= loader.max_components() {
                return Err(GraphError::Subsystem {
                    id: c.id.clone(),
                    message: format!(
                        "{origin}: the circuit has more than {} components; raise the limit with --max-components",
                        loader.max_components()
                    ),
                });
            }
            components.push(Component { origin: origin.clone(), ..c.clone() });
            continue;
        };
        let (path, sub) = match sub_source {
            SubSource::BuiltIn(entry) => (PathBuf::from(crate::library::origin(entry)), crate::library::netlist(entry)?),
            SubSource::File { path, written } => {
                check_chain(chain, &path, &c.id)?;
                let text = loader.read(&path).map_err(|message| GraphError::SubsystemFile {
                    file: origin.clone(),
                    id: c.id.clone(),
                    path: crate::escape(&path.display().to_string()),
                    written: crate::escape(&written),
                    message: format!("{message}{}", built_in_hint(&written)),
                })?;
                let sub = parse(&text, &path.display().to_string())?;
                (path, sub)
            }
        };
        chain.push(path.clone());
        let inner = expand(loader, &sub, &path, chain)?;
        chain.pop();
        if components.len() + inner.components.len() > loader.max_components() {
            return Err(GraphError::Subsystem {
                id: c.id.clone(),
                message: format!(
                    "{origin}: the circuit expands to more than {} components (subsystems included); raise the limit with --max-components",
                    loader.max_components()
                ),
            });
        }
        let interface = sub.interface.clone().unwrap_or_default();
        let prefix = |name: &str| format!("{}.{name}", c.id);
        let mut inner_components: Vec<Component> = inner
            .components
            .into_iter()
            .map(|ic| Component { id: prefix(&ic.id), scopes: prefix_scopes(&c.id, ic.scopes), ..ic })
            .collect();
        let mut inner_parameters: Vec<FlatParameter> = inner
            .parameters
            .into_iter()
            .map(|p| FlatParameter { name: prefix(&p.name), scope: prefix_scope(&c.id, &p.scope), ..p })
            .collect();
        for (name, targets) in inner.aliases {
            aliases.insert(prefix(&name), targets.iter().map(|t| prefix(t)).collect());
        }
        for (name, targets) in &interface.params {
            let mut full = Vec::new();
            for target in targets {
                let (tid, tparam) = split_ref(target).ok_or_else(|| GraphError::Subsystem {
                    id: c.id.clone(),
                    message: format!("{}: bad interface target \"{target}\"", path.display()),
                })?;
                if !inner_components.iter().any(|ic| ic.id == prefix(tid)) {
                    return Err(GraphError::Subsystem {
                        id: c.id.clone(),
                        message: format!("{}: interface parameter \"{name}\" points to unknown component \"{tid}\"", path.display()),
                    });
                }
                full.push(format!("{}.{tparam}", prefix(tid)));
            }
            aliases.insert(prefix(name), full);
        }
        // values the instance gives: interface parameters set their targets,
        // declared parameters take the value; both evaluated in this netlist's scope
        let scope = String::new();
        for (name, value) in c.params.iter().chain(c.init.iter()) {
            if let Some(targets) = interface.params.get(name) {
                for target in targets {
                    let (tid, tparam) = split_ref(target).unwrap_or_default();
                    if let Some(comp) = inner_components.iter_mut().find(|ic| ic.id == prefix(tid)) {
                        comp.init.remove(tparam);
                        comp.params.insert(tparam.to_string(), value.clone());
                        comp.scopes.insert(tparam.to_string(), scope.clone());
                    }
                }
            } else if let Some(p) = inner_parameters.iter_mut().find(|p| p.name == prefix(name)) {
                p.value = value.clone();
                p.scope = scope.clone();
                p.origin = origin.clone();
            } else {
                let mut known: Vec<&str> = interface.params.keys().map(String::as_str).collect();
                known.extend(sub.parameters.keys().map(String::as_str));
                let hint = blocks::suggest::did_you_mean(name, known.iter().copied());
                return Err(GraphError::Component {
                    file: origin.clone(),
                    id: c.id.clone(),
                    message: format!("unknown parameter \"{}\"{hint} ({} has: {})", crate::escape(name), path.display(), known.join(", ")),
                });
            }
        }
        components.append(&mut inner_components);
        parameters.append(&mut inner_parameters);
        for (a, b) in inner.connections {
            connections.push((prefix(&a), prefix(&b)));
        }
        for (name, target) in &interface.ports {
            exposed.insert(prefix(name), prefix(target));
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
        parameters,
        aliases,
        origin,
        inputs: netlist.interface.as_ref().map(|i| i.inputs.clone()).unwrap_or_default(),
        outputs: netlist.interface.as_ref().map(|i| i.outputs.clone()).unwrap_or_default(),
    })
}

fn prefix_scope(instance: &str, scope: &str) -> String {
    if scope.is_empty() {
        instance.to_string()
    } else {
        format!("{instance}.{scope}")
    }
}

/// Scopes recorded inside an instance move into it with the ids.
fn prefix_scopes(instance: &str, scopes: BTreeMap<String, String>) -> BTreeMap<String, String> {
    scopes.into_iter().map(|(param, scope)| (param, prefix_scope(instance, &scope))).collect()
}

/// Read a `--set` value: a plain number is SI, anything else keeps its text (with unit).
pub fn value_from_text(text: &str) -> Value {
    match text.trim().parse::<f64>() {
        // a run of digits beyond f64 stays text, so the unit parser refuses it quoting the input
        Ok(x) if x.is_finite() => Value::Number(x),
        Ok(_) => Value::Text(text.trim().to_string()),
        Err(_) => Value::Text(text.trim().to_string()),
    }
}

/// The forms `--set` takes, for its messages.
const SET_FORM: &str = "expected ID.PARAM=VALUE (e.g. supply.p=6 bar), or NAME=VALUE for a netlist parameter";

/// Names for a message: the first few, then how many there are in all.
fn name_list<S: AsRef<str>>(names: &[S]) -> String {
    const SHOWN: usize = 12;
    let shown: Vec<&str> = names.iter().take(SHOWN).map(AsRef::as_ref).collect();
    if names.len() > SHOWN {
        format!("{}, … ({} in all)", shown.join(", "), names.len())
    } else {
        shown.join(", ")
    }
}

/// Apply an override "NAME=VALUE" to the flat netlist: a parameter
/// (`p_supply`, `cyl.bore`), an interface parameter of a subsystem
/// (`cyl.T0`), a component parameter (`supply.p`, `cyl.piston.mass`),
/// `gas.model`/`gas.species` or `simulation.<setting>`. The value may be an
/// expression (`"rod.p0== supply.p"`), evaluated at the top level.
pub fn apply_set(flat: &mut FlatNetlist, assignment: &str) -> Result<(), GraphError> {
    let bad = |message: &str| GraphError::Set { assignment: crate::escape(assignment), message: message.to_string() };
    let (target, value) = assignment.split_once('=').ok_or_else(|| bad(SET_FORM))?;
    let target = target.trim();
    if target.is_empty() {
        return Err(bad(&format!("nothing before \"=\": {SET_FORM}")));
    }
    if let Some(p) = flat.parameters.iter_mut().find(|p| p.name == target) {
        p.value = value_from_text(value);
        p.scope = String::new();
        return Ok(());
    }
    if let Some(targets) = flat.aliases.get(target).cloned() {
        for t in targets {
            set_component_value(flat, &t, value).map_err(|m| bad(&m))?;
        }
        return Ok(());
    }
    let (id, param) = split_ref(target).ok_or_else(|| {
        let known: Vec<&str> = flat.parameters.iter().map(|p| p.name.as_str()).filter(|n| !n.contains('.')).collect();
        if known.is_empty() {
            bad(&format!("\"{}\" is not ID.PARAM: {SET_FORM}", crate::escape(target)))
        } else {
            bad(&format!("no parameter \"{}\" (parameters: {}; or {SET_FORM})", crate::escape(target), name_list(&known)))
        }
    })?;
    if id == "simulation" {
        return apply_simulation_set(&mut flat.simulation, param, value).map_err(|m| bad(&m));
    }
    if let Some(words) = gas_setting_words(flat, id, param) {
        return apply_gas_set(&mut flat.gas, param, value, words.map_err(|m| bad(&m))?).map_err(|m| bad(&m));
    }
    set_component_value(flat, target, value).map_err(|m| bad(&m))
}

/// Write `value` into `id.param` of a component, as a top-level value.
fn set_component_value(flat: &mut FlatNetlist, target: &str, value: &str) -> Result<(), String> {
    let (id, param) = split_ref(target).ok_or_else(|| SET_FORM.to_string())?;
    let scope_ids = |flat: &FlatNetlist| -> Vec<String> {
        let mut ids: Vec<String> = flat.components.iter().map(|c| c.id.clone()).collect();
        ids.sort();
        ids
    };
    let Some(comp) = flat.components.iter_mut().find(|c| c.id == id) else {
        let is_instance = flat.components.iter().any(|c| c.id.starts_with(&format!("{id}.")));
        return Err(if is_instance {
            let names: Vec<String> = flat
                .parameters
                .iter()
                .map(|p| p.name.clone())
                .chain(flat.aliases.keys().cloned())
                .filter_map(|n| n.strip_prefix(&format!("{id}.")).map(str::to_string))
                .filter(|n| !n.contains('.'))
                .collect();
            format!("subsystem \"{}\" has no parameter \"{}\" (it has: {})", crate::escape(id), crate::escape(param), name_list(&names))
        } else {
            let ids = scope_ids(flat);
            let hint = blocks::suggest::did_you_mean(id, ids.iter().map(String::as_str));
            format!("no component \"{}\"{hint} (components: {})", crate::escape(id), name_list(&ids))
        });
    };
    // a misspelt parameter is refused here, where it is set (Python's Model.set
    // raises at once), not when the circuit is next built
    if let Ok(ty) = blocks::registry::block_type(&comp.kind) {
        if !ty.params.iter().any(|s| s.name == param) {
            let hint = blocks::suggest::did_you_mean(param, ty.params.iter().map(|s| s.name));
            let accepted: Vec<&str> = ty.params.iter().map(|s| s.name).collect();
            return Err(format!(
                "component \"{}\": unknown parameter \"{}\"{hint} (accepted: {})",
                crate::escape(id),
                crate::escape(param),
                accepted.join(", ")
            ));
        }
    }
    let in_init = comp.init.remove(param).is_some();
    comp.params.remove(param);
    let map = if in_init { &mut comp.init } else { &mut comp.params };
    map.insert(param.to_string(), value_from_text(value));
    comp.scopes.insert(param.to_string(), String::new());
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
        "initial" => {
            let word = InitialMode::NAMES
                .iter()
                .find(|w| w.eq_ignore_ascii_case(value.trim()))
                .ok_or_else(|| format!("unknown initial mode \"{value}\" ({})", InitialMode::NAMES.join(", ")))?;
            sim.initial = if *word == "rest" { InitialMode::Rest } else { InitialMode::Given };
        }
        "method" => {
            let word = MethodName::NAMES
                .iter()
                .find(|w| w.eq_ignore_ascii_case(value.trim()))
                .ok_or_else(|| format!("unknown method \"{value}\" ({})", MethodName::NAMES.join(", ")))?;
            sim.method = if *word == "ros34pw2" { MethodName::Ros34pw2 } else { MethodName::Rodas4 };
        }
        _ => {
            return Err(format!(
                "unknown simulation setting \"{param}\" (rtol, atol, t_end, cycles, sample_interval, max_step, initial, method)"
            ))
        }
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
        apply_set(&mut f, "gas.T0=300 K").unwrap();
        assert!(f.components[0].params.contains_key("T0"));
        // "gas.model" names the component's (missing) parameter, not the gas
        let e = apply_set(&mut f, "gas.model=real").unwrap_err().to_string();
        assert!(e.contains("component \"gas\"") && e.contains("\"model\""), "{e}");
        assert_eq!(f.gas.model, GasModelName::Ideal);
    }
}
