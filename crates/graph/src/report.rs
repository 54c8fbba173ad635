//! Human-readable reports of a wired circuit: the causality table printed by
//! `pneumo check`, and a Graphviz rendering.

use crate::circuit::{Circuit, NodeCausality};
use blocks::block::PortKind;
use std::fmt::Write;

fn role(kind: PortKind) -> &'static str {
    match kind {
        PortKind::PneumaticEffort => "effort (integral causality: imposes p, T)",
        PortKind::PneumaticFlow => "flow (resistive, conductance form)",
        PortKind::MechanicalInertia => "inertia (integral causality: imposes x, v)",
        PortKind::MechanicalForce => "force",
        PortKind::SignalIn => "signal in",
        PortKind::SignalOut => "signal out",
    }
}

/// The causality table: components, states, nodes and how each gets its effort.
pub fn causality_table(c: &Circuit) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "circuit {} — gas model {}", c.name, c.gas.name());
    let _ = writeln!(s, "\ncomponents ({}):", c.instances.len());
    let _ = writeln!(s, "  {:<18} {:<20} states", "id", "type");
    for inst in &c.instances {
        let states: Vec<String> = inst.block.states().iter().map(|st| format!("{} [{}]", st.name, st.unit)).collect();
        let _ = writeln!(
            s,
            "  {:<18} {:<20} {}",
            inst.id,
            inst.block.type_name(),
            if states.is_empty() { "-".into() } else { states.join(", ") }
        );
    }
    let _ = writeln!(s, "\npneumatic nodes ({}):", c.pneumatic_nodes.len());
    for (i, node) in c.pneumatic_nodes.iter().enumerate() {
        let how = match node.causality {
            NodeCausality::Effort(r) => format!("p, T from {}", c.port_name(r)),
            NodeCausality::Junction => "algebraic junction: p solved so that the flows balance (bracketed root solve)".into(),
        };
        let _ = writeln!(s, "  P{i}: {how}");
        for &r in &node.ports {
            let _ = writeln!(s, "      {:<24} {}", c.port_name(r), role(c.port_kind(r)));
        }
    }
    let _ = writeln!(s, "\nmechanical nodes ({}):", c.mechanical_nodes.len());
    for (i, node) in c.mechanical_nodes.iter().enumerate() {
        let _ = writeln!(s, "  M{i}: x, v from {} (stick-slip and stops decided on this node)", c.port_name(node.inertia));
        for &r in &node.ports {
            let _ = writeln!(s, "      {:<24} {}", c.port_name(r), role(c.port_kind(r)));
        }
    }
    let mut signals = Vec::new();
    for inst in &c.instances {
        let inputs = inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalIn);
        for (p, src) in inputs.zip(&inst.signal_sources) {
            signals.push(format!("  {:<24} <- {}", format!("{}.{}", inst.id, p.name), c.port_name(*src)));
        }
    }
    let _ = writeln!(s, "\nsignals ({}):", signals.len());
    for line in signals {
        let _ = writeln!(s, "{line}");
    }
    if !c.junction_clusters.is_empty() {
        let _ = writeln!(s, "\nalgebraic loops: {} (restrictions in series, solved at every evaluation)", c.junction_clusters.len());
    }
    s
}

/// Graphviz rendering of the component graph.
pub fn dot(c: &Circuit) -> String {
    let mut s = String::from("digraph circuit {\n  rankdir=LR;\n  node [shape=box, fontname=\"Helvetica\"];\n");
    for inst in &c.instances {
        let _ = writeln!(s, "  \"{}\" [label=\"{}\\n{}\"];", inst.id, inst.id, inst.block.type_name());
    }
    for (i, node) in c.pneumatic_nodes.iter().enumerate() {
        let shape = match node.causality {
            NodeCausality::Effort(_) => "circle",
            NodeCausality::Junction => "doublecircle",
        };
        let _ = writeln!(s, "  \"P{i}\" [shape={shape}, label=\"P{i}\", width=0.3];");
        for &r in &node.ports {
            let _ = writeln!(
                s,
                "  \"{}\" -> \"P{i}\" [dir=none, label=\"{}\"];",
                c.instances[r.block].id,
                c.instances[r.block].block.ports()[r.port].name
            );
        }
    }
    for (i, node) in c.mechanical_nodes.iter().enumerate() {
        let _ = writeln!(s, "  \"M{i}\" [shape=diamond, label=\"M{i}\"];");
        for &r in &node.ports {
            let _ = writeln!(s, "  \"{}\" -> \"M{i}\" [dir=none, style=bold];", c.instances[r.block].id);
        }
    }
    for inst in &c.instances {
        let inputs = inst.block.ports().iter().filter(|p| p.kind == PortKind::SignalIn);
        for (p, src) in inputs.zip(&inst.signal_sources) {
            let _ = writeln!(s, "  \"{}\" -> \"{}\" [style=dashed, label=\"{}\"];", c.instances[src.block].id, inst.id, p.name);
        }
    }
    s.push_str("}\n");
    s
}

/// A value in its display unit ("4 bar"), or SI with the dimension's unit.
pub fn show_value(v: &crate::params::ResolvedValue) -> String {
    let unit = if v.display_unit.is_empty() { crate::params::si_unit(v.dim) } else { v.display_unit.clone() };
    let x = if unit.is_empty() { v.si } else { units::to_unit(v.si, &unit).unwrap_or(v.si) };
    // 10 significant digits hide conversion noise such as 19.999999999999996
    let x: f64 = format!("{x:.9e}").parse().unwrap_or(x);
    let x = units::show::num(x);
    if unit.is_empty() {
        x
    } else {
        format!("{x} {unit}")
    }
}

/// The named parameters and every component value derived from an
/// expression, with their resolved values (printed by `pneumo check`).
pub fn parameter_table(c: &Circuit) -> String {
    use crate::params::SlotKind;
    let mut s = String::new();
    let params: Vec<_> = c.resolved.values.iter().filter(|(_, v)| matches!(v.kind, SlotKind::Parameter { .. })).collect();
    let derived: Vec<_> = c.resolved.values.iter().filter(|(_, v)| !matches!(v.kind, SlotKind::Parameter { .. }) && v.derived()).collect();
    if !params.is_empty() {
        let _ = writeln!(s, "\nparameters ({}):", params.len());
        for (name, v) in params {
            let how = v.expression.as_ref().map(|e| format!("= {e}")).unwrap_or_default();
            let doc = match &v.kind {
                SlotKind::Parameter { description: Some(d) } => d.as_str(),
                _ => "",
            };
            let _ = writeln!(s, "  {:<22} {:<18} {:<28} {}", name, show_value(v), how, crate::escape(doc));
        }
    }
    if !derived.is_empty() {
        let _ = writeln!(s, "\nderived values ({}):", derived.len());
        for (name, v) in derived {
            let _ = writeln!(s, "  {:<22} {:<18} = {}", name, show_value(v), v.expression.as_deref().unwrap_or(""));
        }
    }
    s
}
