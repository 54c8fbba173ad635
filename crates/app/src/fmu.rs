//! The FMU use case: a netlist as an FMI 2.0 Co-Simulation FMU, and the
//! variables both the exporter and the FMU runtime (`crates/fmu`) see in it.
//!
//! An FMU is a zip archive: `modelDescription.xml` (the variables with value
//! references, units, causality and variability), the runtime library
//! `binaries/linux64/<modelIdentifier>.so` (`crates/fmu`, built by
//! `cargo build --release` next to the `pneumo` executable), and the netlist
//! in `resources/` (`model.json`, plus the subsystem files it names at the
//! same relative paths). The runtime reads the netlist at `fmi2Instantiate`
//! and lists its variables with [`variables`], so the value references of the
//! description and of the runtime agree by construction.
//!
//! Variables, in value-reference order: the interface inputs (causality
//! `input`, set at any communication point), the interface outputs
//! (`output`, sampled at communication points), then the top-level netlist
//! parameters given as literals (`parameter`, variability `fixed`: set
//! before initialization; they feed expressions evaluated when the circuit
//! is built). Every value is in the unit the netlist writes for it.
//! The GUID is derived from the SHA-256 of the netlist files, so a runtime
//! given another model's resources refuses to start.

use crate::error::{shown_path, AppError};
use crate::load::Source;
use crate::output::Transaction;
use graph::FlatNetlist;
use std::io::Write;
use std::path::{Path, PathBuf};

/// File name of the runtime library that `cargo build --release` puts next
/// to the `pneumo` executable.
pub const RUNTIME_LIBRARY: &str = "libpneumo_fmu.so";

/// What a variable is to the importer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Input,
    Output,
    Parameter,
}

/// One scalar variable of the FMU (all are `Real`).
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub causality: Causality,
    pub description: Option<String>,
    /// Unit as the netlist writes it ("" for a pure number): SI = value · factor + offset.
    pub unit: String,
    pub factor: f64,
    pub offset: f64,
    pub dim: Option<units::Dimension>,
    /// Start value in `unit` (inputs and parameters).
    pub start: Option<f64>,
}

impl Variable {
    /// SI value of `x` given in the variable's unit.
    pub fn to_si(&self, x: f64) -> f64 {
        x * self.factor + self.offset
    }
    /// Value in the variable's unit of the SI value `si`.
    pub fn in_unit(&self, si: f64) -> f64 {
        (si - self.offset) / self.factor
    }
}

/// The variables of a netlist as an FMU sees them, in value-reference order
/// (see the module documentation).
pub fn variables(flat: &FlatNetlist) -> Result<Vec<Variable>, AppError> {
    let circuit = graph::build_with(flat, graph::Drive::External)?;
    let interface = &circuit.interface;
    let unit = |u: &graph::interface::OuterUnit| if u.text == "1" { String::new() } else { u.text.clone() };
    let mut vars = Vec::new();
    for i in &interface.inputs {
        vars.push(Variable {
            name: i.name.clone(),
            causality: Causality::Input,
            description: i.description.clone(),
            unit: unit(&i.unit),
            factor: i.unit.factor,
            offset: i.unit.offset,
            dim: i.unit.dim,
            start: Some(i.unit.from_si(i.start)),
        });
    }
    for o in &interface.outputs {
        vars.push(Variable {
            name: o.name.clone(),
            causality: Causality::Output,
            description: o.description.clone(),
            unit: unit(&o.unit),
            factor: o.unit.factor,
            offset: o.unit.offset,
            dim: o.unit.dim,
            start: None,
        });
    }
    for p in flat.parameters.iter().filter(|p| p.scope.is_empty() && !p.name.contains('.')) {
        let Some((start, unit)) = literal(&p.value, p.declared_dim, &p.declared_unit) else { continue };
        let parsed = if unit.is_empty() { None } else { units::parse_unit(&unit).ok() };
        vars.push(Variable {
            name: p.name.clone(),
            causality: Causality::Parameter,
            description: p.description.clone(),
            factor: parsed.map_or(1.0, |u| u.factor),
            offset: parsed.map_or(0.0, |u| u.offset),
            dim: parsed.map(|u| u.dimension).or(p.declared_dim),
            unit,
            start: Some(start),
        });
    }
    Ok(vars)
}

/// A parameter value written as a literal: (number in its unit, unit).
fn literal(value: &graph::netlist::Value, dim: Option<units::Dimension>, unit: &str) -> Option<(f64, String)> {
    match value {
        graph::netlist::Value::Number(x) => Some((*x, String::new())),
        graph::netlist::Value::Text(text) if !units::is_expression(text) => {
            let dim = dim?;
            let si = units::parse_quantity(text, dim).ok()?;
            if unit.is_empty() {
                return Some((si, String::new()));
            }
            Some((units::to_unit(si, unit).ok()?, unit.to_string()))
        }
        _ => None,
    }
}

/// The `--set` assignment giving parameter `v` the value `x` (in its unit).
pub fn assignment(v: &Variable, x: f64) -> String {
    format!("{}={x:?} {}", v.name, v.unit).trim_end().to_string()
}

/// The FMU's GUID: the SHA-256 of the netlist files, shaped like a UUID.
pub fn guid(source: &Source) -> String {
    let h = source.sha256();
    format!("{{{}-{}-{}-{}-{}}}", &h[0..8], &h[8..12], &h[12..16], &h[16..20], &h[20..32])
}

/// A name as a C identifier (the FMU's `modelIdentifier`).
pub fn model_identifier(name: &str) -> String {
    let mut id: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if id.is_empty() || id.starts_with(|c: char| c.is_ascii_digit()) {
        id.insert(0, '_');
    }
    id
}

/// Where the runtime library is expected: next to the running executable.
pub fn runtime_beside_executable() -> Result<PathBuf, AppError> {
    let exe = std::env::current_exe().map_err(|e| AppError::Usage(format!("cannot locate the pneumo executable: {e}")))?;
    Ok(exe.parent().unwrap_or(Path::new(".")).join(RUNTIME_LIBRARY))
}

/// Export the netlist at `model` as an FMU at `out`, with the runtime
/// library at `runtime`. Nothing is written unless everything succeeds.
pub fn export(model: &Path, out: &Path, runtime: &Path) -> Result<(), AppError> {
    Transaction::new(&[model]).check_targets(&[out])?;
    let (flat, source) = Source::read(model)?;
    export_source(&flat, &source, out, runtime)
}

/// Export a netlist held in memory (`flat` loaded from `source`, without
/// overrides: the FMU carries the files of `source` as they are) as an FMU
/// at `out`. The Python package's `pneumo.export_fmu` calls this.
pub fn export_source(flat: &FlatNetlist, source: &Source, out: &Path, runtime: &Path) -> Result<(), AppError> {
    let model = source.path.as_path();
    let read: Vec<&Path> = source.files.iter().map(|(p, _)| p.as_path()).collect();
    let tx = Transaction::new(&read);
    tx.check_targets(&[out])?;
    let vars = variables(flat)?;
    if !vars.iter().any(|v| v.causality == Causality::Output) {
        return Err(AppError::Usage(format!(
            "{}: the netlist declares no interface outputs; an FMU needs at least one (docs/netlist.md, \"Model interface\")",
            shown_path(model)
        )));
    }
    let library = std::fs::read(runtime).map_err(|e| {
        AppError::Usage(format!(
            "the FMU runtime library {} is missing ({e}); build it with `cargo build --release` (it is built next to the pneumo executable)",
            shown_path(runtime)
        ))
    })?;
    let circuit = graph::build(flat)?;
    let opts = solve::options_from(&circuit.simulation)?;
    let id = model_identifier(&flat.name);
    let description = netlist_description(source);
    let xml = model_description(&flat.name, &id, description.as_deref(), &guid(source), &vars, opts.t_end);
    let bytes = zip_fmu(&xml, &id, &library, &resources(source)?).map_err(|e| AppError::io(out, e))?;
    let mut tx = tx;
    tx.add(out, &bytes)?;
    tx.commit()
}

/// The top-level netlist's `description`, if any.
fn netlist_description(source: &Source) -> Option<String> {
    let (_, text) = source.files.first()?;
    let json: serde_json::Value = serde_json::from_str(text).ok()?;
    json.get("description")?.as_str().map(str::to_string)
}

/// The files of `resources/`: the netlist as `model.json`, its subsystems at
/// their paths relative to its folder.
fn resources(source: &Source) -> Result<Vec<(String, String)>, AppError> {
    let dir = source.path.parent().unwrap_or(Path::new(""));
    let mut files = Vec::new();
    for (k, (path, text)) in source.files.iter().enumerate() {
        if k == 0 {
            files.push(("model.json".to_string(), text.clone()));
            continue;
        }
        let relative = path.strip_prefix(dir).ok().filter(|r| r.components().all(|c| matches!(c, std::path::Component::Normal(_))));
        let Some(relative) = relative.and_then(|r| r.to_str()) else {
            return Err(AppError::Usage(format!(
                "subsystem file {} is not inside the folder of {}: an FMU carries subsystems at their paths below the model's folder",
                shown_path(path),
                shown_path(&source.path)
            )));
        };
        files.push((relative.to_string(), text.clone()));
    }
    Ok(files)
}

/// `modelDescription.xml` (FMI 2.0 Co-Simulation).
fn model_description(name: &str, id: &str, description: Option<&str>, guid: &str, vars: &[Variable], t_end: f64) -> String {
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x += &format!(
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{}\" guid=\"{guid}\"{} generationTool=\"pneumo {}\" variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n",
        xml_escape(name),
        description.map(|d| format!(" description=\"{}\"", xml_escape(d))).unwrap_or_default(),
        env!("CARGO_PKG_VERSION")
    );
    x += &format!(
        "  <CoSimulation modelIdentifier=\"{id}\" canHandleVariableCommunicationStepSize=\"true\" canGetAndSetFMUstate=\"true\" canNotUseMemoryManagementFunctions=\"true\"/>\n"
    );
    let mut units_seen: Vec<&Variable> = Vec::new();
    for v in vars.iter().filter(|v| !v.unit.is_empty()) {
        if !units_seen.iter().any(|u| u.unit == v.unit) {
            units_seen.push(v);
        }
    }
    if !units_seen.is_empty() {
        x += "  <UnitDefinitions>\n";
        for v in units_seen {
            let mut base = String::new();
            if let Some(d) = v.dim {
                for (name, e) in [("kg", d.mass), ("m", d.length), ("s", d.time), ("K", d.temperature)] {
                    if e != 0 {
                        base += &format!(" {name}=\"{e}\"");
                    }
                }
            }
            if v.factor != 1.0 {
                base += &format!(" factor=\"{:?}\"", v.factor);
            }
            if v.offset != 0.0 {
                base += &format!(" offset=\"{:?}\"", v.offset);
            }
            x += &format!("    <Unit name=\"{}\"><BaseUnit{base}/></Unit>\n", xml_escape(&v.unit));
        }
        x += "  </UnitDefinitions>\n";
    }
    x += &format!("  <DefaultExperiment startTime=\"0\" stopTime=\"{t_end:?}\"/>\n");
    x += "  <ModelVariables>\n";
    for (vr, v) in vars.iter().enumerate() {
        let (causality, variability, initial) = match v.causality {
            Causality::Input => ("input", "continuous", ""),
            Causality::Output => ("output", "continuous", ""),
            Causality::Parameter => ("parameter", "fixed", " initial=\"exact\""),
        };
        x += &format!(
            "    <ScalarVariable name=\"{}\" valueReference=\"{vr}\" causality=\"{causality}\" variability=\"{variability}\"{initial}{}>\n",
            xml_escape(&v.name),
            v.description.as_deref().map(|d| format!(" description=\"{}\"", xml_escape(d))).unwrap_or_default()
        );
        let unit = if v.unit.is_empty() { String::new() } else { format!(" unit=\"{}\"", xml_escape(&v.unit)) };
        let start = v.start.map(|s| format!(" start=\"{s:?}\"")).unwrap_or_default();
        x += &format!("      <Real{unit}{start}/>\n    </ScalarVariable>\n");
    }
    x += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
    let outputs: Vec<usize> = vars.iter().enumerate().filter(|(_, v)| v.causality == Causality::Output).map(|(k, _)| k + 1).collect();
    for k in &outputs {
        x += &format!("      <Unknown index=\"{k}\"/>\n");
    }
    x += "    </Outputs>\n    <InitialUnknowns>\n";
    for k in &outputs {
        x += &format!("      <Unknown index=\"{k}\"/>\n");
    }
    x += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
    x
}

fn xml_escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s += "&amp;",
            '<' => s += "&lt;",
            '>' => s += "&gt;",
            '"' => s += "&quot;",
            c if c.is_control() => s += &format!("&#{};", c as u32),
            c => s.push(c),
        }
    }
    s
}

/// The FMU archive in memory.
fn zip_fmu(xml: &str, id: &str, library: &[u8], resources: &[(String, String)]) -> std::io::Result<Vec<u8>> {
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    zip.start_file("modelDescription.xml", deflated)?;
    zip.write_all(xml.as_bytes())?;
    zip.start_file(format!("binaries/linux64/{id}.so"), deflated.unix_permissions(0o755))?;
    zip.write_all(library)?;
    for (path, text) in resources {
        zip.start_file(format!("resources/{path}"), deflated)?;
        zip.write_all(text.as_bytes())?;
    }
    Ok(zip.finish()?.into_inner())
}
