//! Checking a netlist (`pneumo check`, Python's `Model.check`): build the
//! circuit, its causality and parameter tables and its rest state, and the
//! circuit as Graphviz; and the listing of every block type (`pneumo blocks`).

use crate::error::AppError;
use std::fmt::Write;
use std::path::PathBuf;

/// What to check: a netlist file, overrides, and where to write the circuit
/// as Graphviz (`pneumo check --set … --dot f.dot`).
#[derive(Debug, Clone, Default)]
pub struct CheckOptions {
    /// Netlist file (JSON).
    pub model: PathBuf,
    /// Overrides `ID.PARAM=VALUE`, applied in order.
    pub sets: Vec<String>,
    /// Write the circuit as a Graphviz file.
    pub dot: Option<PathBuf>,
}

/// What `pneumo check` finds: the causality and parameter tables and the
/// rest state (the text it prints) and the circuit as Graphviz.
pub struct Checked {
    pub text: String,
    pub dot: String,
}

/// Build the circuit of `flat`, check its settings and compute its rest
/// state; `warn` receives the circuit's warnings as soon as it is built.
pub fn check(flat: &graph::FlatNetlist, warn: &mut dyn FnMut(&[graph::Warning])) -> Result<Checked, AppError> {
    let circuit = graph::build(flat)?;
    solve::options_from(&circuit.simulation)?;
    warn(&circuit.warnings);
    let dot = graph::report::dot(&circuit);
    let mut text = graph::report::causality_table(&circuit);
    text.push_str(&graph::report::parameter_table(&circuit));
    let rest = circuit.simulation.initial == graph::netlist::InitialMode::Rest;
    let mut model = solve::Model::new(circuit);
    if rest {
        let report = solve::rest::apply(&mut model).map_err(|e| AppError::Solve(Box::new(e.into())))?;
        let _ = writeln!(text, "\ninitial state at rest ({} values):", report.values.len());
        for v in &report.values {
            let shown = match v.param {
                "p0" => format!("{:.6} bar", v.value / 1e5),
                "T0" => format!("{:.2} K", v.value),
                _ => format!("{:.3} mm", v.value * 1e3),
            };
            let _ = writeln!(text, "  {:<22} {:<18} {}", format!("{}.{}", v.id, v.param), shown, v.reason);
        }
    }
    Ok(Checked { text, dot })
}

/// Check the netlist file of `o` with its overrides and write the Graphviz
/// file if asked; `warn` receives the circuit's warnings as soon as it is
/// built. Returns what [`check`] finds (the text `pneumo check` prints).
pub fn check_file(o: &CheckOptions, warn: &mut dyn FnMut(&[graph::Warning])) -> Result<Checked, AppError> {
    let (flat, inputs) = crate::load::netlist_with_files(&o.model, &o.sets)?;
    let inputs: Vec<&std::path::Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut outputs = crate::output::Transaction::new(&inputs);
    if let Some(dot) = &o.dot {
        outputs.check_targets(&[dot])?;
    }
    let checked = check(&flat, warn)?;
    if let Some(path) = &o.dot {
        outputs.add(path, checked.dot.as_bytes())?;
        outputs.commit()?;
    }
    Ok(checked)
}

/// All block types by family, with their ports (domain, causal role, unit),
/// recorded outputs and parameters (for `pneumo blocks`).
pub fn block_listing() -> String {
    use blocks::block::{Domain, PortKind};
    use blocks::registry::Family;
    let mut s = String::new();
    for family in Family::ALL {
        let members: Vec<_> = blocks::registry::TYPES.iter().filter(|t| t.family == *family).collect();
        if members.is_empty() {
            continue;
        }
        let _ = writeln!(s, "== {} ==\n", family.title());
        for t in members {
            let _ = writeln!(s, "{} — {}", t.name, t.doc);
            let _ = writeln!(s, "  ports:");
            for p in t.ports {
                let role = match p.kind {
                    PortKind::PneumaticEffort => "pneumatic, imposes p and T",
                    PortKind::PneumaticFlow => "pneumatic, flow",
                    PortKind::MechanicalInertia => "mechanical, moving mass",
                    PortKind::MechanicalForce => "mechanical, force",
                    PortKind::SignalIn => "signal in",
                    PortKind::SignalOut => "signal out",
                };
                let unit = match p.kind.domain() {
                    Domain::Signal if p.unit.is_empty() => "[as its input]".to_string(),
                    Domain::Signal => format!("[{}]", p.unit),
                    Domain::Pneumatic => "[Pa, K; kg/s, W]".to_string(),
                    Domain::Mechanical => "[m, m/s; N]".to_string(),
                };
                let _ = writeln!(s, "    {:<20} {:<28} {:<18} {}", p.name, role, unit, p.doc);
            }
            if !t.outputs.is_empty() {
                let outs: Vec<String> =
                    t.outputs.iter().map(|o| format!("{} [{}]", o.name, if o.unit.is_empty() { "as input" } else { o.unit })).collect();
                let _ = writeln!(s, "  recorded: {}", outs.join(", "));
            }
            let _ = writeln!(s, "  parameters:");
            for p in t.params {
                let default = match (p.default, p.kind) {
                    (None, _) => "required".to_string(),
                    (Some(_), blocks::params::ParamKind::Words | blocks::params::ParamKind::List(_)) => "-".to_string(),
                    (Some(d), blocks::params::ParamKind::Choice(opts)) => opts.get(d as usize).copied().unwrap_or("").to_string(),
                    (Some(d), _) if d.is_infinite() => "inf".into(),
                    (Some(d), _) => display_default(d, p.display_unit),
                };
                let _ = writeln!(s, "    {:<20} {:<12} default {:<10} {}", p.name, p.display_unit, default, p.doc);
            }
            s.push('\n');
        }
    }
    s.push_str(&built_in_listing());
    s
}

/// The built-in sub-circuits (`"type": "cylinder"`): ports and parameters with defaults.
fn built_in_listing() -> String {
    let mut s = String::from("== Built-in components (sub-circuits, \"type\": NAME from any netlist) ==\n\n");
    for entry in graph::library::ENTRIES {
        let Ok(n) = graph::library::netlist(entry) else { continue };
        let doc = n.description.as_deref().unwrap_or("");
        let _ = writeln!(s, "{} — {doc}", entry.name);
        if let Some(interface) = &n.interface {
            let _ = writeln!(s, "  ports: {}", interface.ports.keys().map(String::as_str).collect::<Vec<_>>().join(", "));
            if !interface.params.is_empty() {
                let _ = writeln!(s, "  initial values: {}", interface.params.keys().map(String::as_str).collect::<Vec<_>>().join(", "));
            }
        }
        let _ = writeln!(s, "  parameters:");
        for (name, decl) in &n.parameters {
            let value = match decl.value() {
                graph::netlist::Value::Number(x) => x.to_string(),
                graph::netlist::Value::Text(t) => t.clone(),
                graph::netlist::Value::List(_) => "(list)".into(),
            };
            let _ = writeln!(s, "    {name:<20} default {value:<16} {}", decl.description().unwrap_or(""));
        }
        s.push('\n');
    }
    s
}

/// A default (stored in SI) in the parameter's display unit, as listed beside it.
fn display_default(si: f64, display_unit: &str) -> String {
    let v = if display_unit.is_empty() { si } else { units::to_unit(si, display_unit).unwrap_or(si) };
    // 12 significant digits hide conversion noise such as 19.999999999999996
    let rounded: f64 = format!("{v:.11e}").parse().unwrap_or(v);
    format!("{rounded}")
}
