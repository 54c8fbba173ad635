//! Warnings about input that builds but is probably not what the user
//! meant, found by comparing the [`blocks::block::Fact`]s blocks state:
//! - geometry of one actuator disagreeing between blocks (the piston's stroke
//!   against the rod chamber's gas column, bores and rod diameters of the
//!   chambers and the piston, a limit switch placed beyond the stroke);
//! - a supply below the ambient pressure;
//! - a command source whose levels lie strictly between the released and
//!   actuated levels of the on/off valve it drives.
//!
//! Facts about a moving mass are grouped by mechanical node; a fact on a
//! signal input belongs to the node of the block that drives the input.

use crate::circuit::{Circuit, PortRef};
use crate::{GraphError, Warning};
use blocks::block::{Domain, Fact};
use std::collections::BTreeMap;

/// Relative difference below which two lengths agree.
const SAME: f64 = 1e-9;

/// Comparable geometric facts, by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Geometry {
    Stroke,
    Bore,
    Rod,
}

/// Mechanical node a port belongs to, following a signal input to its driver.
fn mechanical_node(c: &Circuit, r: PortRef) -> Option<usize> {
    let inst = &c.instances[r.block];
    let kind = inst.block.ports()[r.port].kind;
    match kind.domain() {
        Domain::Mechanical => inst.port_nodes[r.port],
        Domain::Signal => {
            let k = inst.block.ports()[..r.port].iter().filter(|p| p.kind == blocks::block::PortKind::SignalIn).count();
            let src = if kind == blocks::block::PortKind::SignalIn { *inst.signal_sources.get(k)? } else { r };
            let driver = &c.instances[src.block];
            let mech: Vec<usize> = driver
                .block
                .ports()
                .iter()
                .zip(&driver.port_nodes)
                .filter(|(p, _)| p.kind.domain() == Domain::Mechanical)
                .filter_map(|(_, n)| *n)
                .collect();
            (mech.len() == 1).then(|| mech[0])
        }
        Domain::Pneumatic => None,
    }
}

/// A length in mm for a message, rounded to 1 nm unless that hides it.
fn mm(x: f64) -> String {
    let v = x * 1e3;
    let rounded = (v * 1e6).round() / 1e6;
    format!("{} mm", units::show::num(if rounded != 0.0 && rounded.is_finite() { rounded } else { v }))
}

/// All warnings for a built circuit.
pub fn check(c: &Circuit) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let warn = |warnings: &mut Vec<Warning>, message: String| warnings.push(Warning { file: String::new(), message });
    // (node, kind) → (value, "id.param") of the first block stating it
    let mut geometry: BTreeMap<(usize, Geometry), (f64, String)> = BTreeMap::new();
    let mut switches: Vec<(usize, f64, String)> = Vec::new();
    let mut supplies: Vec<(f64, String)> = Vec::new();
    let mut ambient: Option<(f64, String)> = None;
    let mut levels: BTreeMap<PortRef, Vec<f64>> = BTreeMap::new();
    let mut thresholds: Vec<(PortRef, f64, f64)> = Vec::new();
    for (bi, inst) in c.instances.iter().enumerate() {
        for (port, fact) in inst.block.facts() {
            let r = PortRef { block: bi, port };
            let who = |what: &str| format!("{}.{what}", inst.id);
            let geo = |kind: Geometry, x: f64, what: &str| mechanical_node(c, r).map(|n| ((n, kind), (x, who(what))));
            let entry = match fact {
                Fact::Stroke(x) => geo(Geometry::Stroke, x, "stroke"),
                Fact::Bore(x) => geo(Geometry::Bore, x, "bore"),
                Fact::RodDiameter(x) => geo(Geometry::Rod, x, "rod_diameter"),
                Fact::SwitchPosition(x) => {
                    if let Some(n) = mechanical_node(c, r) {
                        switches.push((n, x, who("stroke")));
                    }
                    None
                }
                Fact::SupplyPressure(p) => {
                    supplies.push((p, who("p")));
                    None
                }
                Fact::AmbientPressure(p) => {
                    if ambient.as_ref().is_none_or(|(q, _)| p > *q) {
                        ambient = Some((p, who("p")));
                    }
                    None
                }
                Fact::CommandLevels(v) => {
                    levels.insert(r, v);
                    None
                }
                Fact::CommandThresholds { released, actuated } => {
                    thresholds.push((r, released, actuated));
                    None
                }
                Fact::SetPressure(_) => None, // an error, see `errors`
            };
            if let Some((key, (x, name))) = entry {
                match geometry.get(&key) {
                    Some((y, first)) if (x - y).abs() > SAME * x.abs().max(y.abs()) => {
                        warn(&mut warnings, format!("{first} = {} but {name} = {}: the geometry of one actuator disagrees", mm(*y), mm(x)))
                    }
                    Some(_) => {}
                    None => {
                        geometry.insert(key, (x, name));
                    }
                }
            }
        }
    }
    for (node, x, name) in switches {
        if let Some((stroke, by)) = geometry.get(&(node, Geometry::Stroke)) {
            if x > *stroke * (1.0 + SAME) {
                warn(&mut warnings, format!("{name} trips at {} but {by} = {}: the switch is never reached", mm(x), mm(*stroke)));
            }
        }
    }
    let (p_amb, amb_name) = ambient.unwrap_or((units::STANDARD_ATMOSPHERE, "the standard atmosphere".into()));
    for (p, name) in supplies {
        if p < p_amb {
            warn(
                &mut warnings,
                format!(
                    "{name} = {} bar is below {amb_name} ({} bar): pressures are absolute",
                    units::show::fixed(p / 1e5, 4),
                    units::show::fixed(p_amb / 1e5, 4)
                ),
            );
        }
    }
    for (r, released, actuated) in thresholds {
        let inst = &c.instances[r.block];
        let k = inst.block.ports()[..r.port].iter().filter(|p| p.kind == blocks::block::PortKind::SignalIn).count();
        let Some(src) = inst.signal_sources.get(k) else { continue };
        let Some(values) = levels.get(src) else { continue };
        let (lo, hi) = (released.min(actuated), released.max(actuated));
        if let Some(v) = values.iter().find(|v| **v > lo && **v < hi) {
            warn(
                &mut warnings,
                format!(
                    "{} takes the value {}, between the released ({}) and actuated ({}) levels of {}",
                    c.port_name(*src),
                    units::show::num(*v),
                    units::show::num(released),
                    units::show::num(actuated),
                    c.port_name(r)
                ),
            );
        }
    }
    warnings
}

/// Input that cannot work: a regulator whose set pressure is not below the
/// supply that reaches its supply port (through any pneumatic path, not
/// through other regulators, which count as sources at their set pressure).
pub fn errors(c: &Circuit) -> Result<(), GraphError> {
    for (bi, inst) in c.instances.iter().enumerate() {
        for (port, fact) in inst.block.facts() {
            let Fact::SetPressure(p_set) = fact else { continue };
            let Some(node) = inst.port_nodes.get(port).copied().flatten() else { continue };
            let Some((p_supply, source)) = available_supply(c, node, bi) else { continue };
            if p_set >= p_supply {
                return Err(GraphError::Inconsistent {
                    id: inst.id.clone(),
                    param: "p_set".into(),
                    message: format!(
                        "set to {} bar, not below the supply that reaches it ({source} = {} bar); pressures are absolute",
                        units::show::fixed(p_set / 1e5, 4),
                        units::show::fixed(p_supply / 1e5, 4)
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Highest supply pressure reaching pneumatic node `start` without passing
/// through block `skip`, with the name of the value that sets it.
fn available_supply(c: &Circuit, start: usize, skip: usize) -> Option<(f64, String)> {
    let mut seen = vec![false; c.pneumatic_nodes.len()];
    let mut queue = std::collections::VecDeque::from([start]);
    seen[start] = true;
    let mut best: Option<(f64, String)> = None;
    let mut offer = |p: f64, name: String| {
        if best.as_ref().is_none_or(|(q, _)| p > *q) {
            best = Some((p, name));
        }
    };
    while let Some(n) = queue.pop_front() {
        for r in &c.pneumatic_nodes[n].ports {
            if r.block == skip {
                continue;
            }
            let inst = &c.instances[r.block];
            let facts = inst.block.facts();
            let supply_here = facts.iter().find_map(|(k, f)| match f {
                Fact::SupplyPressure(p) if *k == r.port => Some(*p),
                _ => None,
            });
            if let Some(p) = supply_here {
                offer(p, format!("{}.p", inst.id));
                continue;
            }
            if let Some((k, p)) = facts.iter().find_map(|(k, f)| if let Fact::SetPressure(p) = f { Some((*k, *p)) } else { None }) {
                // another regulator: a source at its set pressure if reached from its outlet side
                if k != r.port {
                    offer(p, format!("{}.p_set", inst.id));
                }
                continue;
            }
            for (pi, (spec, node)) in inst.block.ports().iter().zip(&inst.port_nodes).enumerate() {
                if pi == r.port || spec.kind.domain() != Domain::Pneumatic {
                    continue;
                }
                if let Some(m) = *node {
                    if !seen[m] {
                        seen[m] = true;
                        queue.push_back(m);
                    }
                }
            }
        }
    }
    best
}
